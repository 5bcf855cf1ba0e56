/* The bind(C) API through include/tubes.h, as a C user calls it. Each check prints one line;
 * exit 1 if any failed. */
#include "tubes.h"
#include <math.h>
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#include <stdio.h>
#include <string.h>

static int nfail = 0, nchecks = 0;
static void check(const char *name, int ok, double got, double want) {
  nchecks++;
  if (!ok) nfail++;
  printf("%s %s (got %.17g, want %.17g)\n", ok ? "ok  " : "FAIL", name, got, want);
}

int tubes_method_code(const char *name);   /* src/io/tubes_input.c: &integrator method's registered list */

int main(void) {
  /* a method's code is its place in the registry's list of names: the enum must follow it */
  {
    static const struct { const char *name; int code; } m[] = {
        {"dop853", TUBES_METHOD_DOP853}, {"rk4", TUBES_METHOD_RK4}, {"tao2", TUBES_METHOD_TAO2},
        {"tao4", TUBES_METHOD_TAO4}, {"tao6", TUBES_METHOD_TAO6}, {"gauss4", TUBES_METHOD_GAUSS4},
        {"gauss6", TUBES_METHOD_GAUSS6}, {"gauss8", TUBES_METHOD_GAUSS8}, {"gsl_rk8pd", TUBES_METHOD_GSL_RK8PD},
        {"gsl_rk4imp", TUBES_METHOD_GSL_RK4IMP}, {"cvode_adams", TUBES_METHOD_CVODE_ADAMS},
        {"arkode_erk8", TUBES_METHOD_ARKODE_ERK8}, {"taylor", TUBES_METHOD_TAYLOR}, {"auto", TUBES_METHOD_AUTO}};
    int bad = 0;
    for (size_t i = 0; i < sizeof m / sizeof m[0]; i++) bad += tubes_method_code(m[i].name) != m[i].code;
    check("method codes: the registry's list of names in TUBES_METHOD_* order", bad == 0, bad, 0);
    check("method codes: an unknown name is 0", tubes_method_code("dop") == 0, tubes_method_code("dop"), 0);
  }
  const char sys[TUBES_LSYSTEM] = "rolling_ball";
  double model[TUBES_MAXPARAM] = {0};
  enum { NMAX = 32, MD = TUBES_MAXDOF };
  /* the model by name: its parameters and defaults come from the library's table */
  {
    int ndof = 0, np = 0, si, sd;
    char pn[TUBES_MAXPARAM * TUBES_LPARAM], pu[TUBES_MAXPARAM * TUBES_LUNITS], pd[TUBES_MAXPARAM * TUBES_LDOC];
    char sum[TUBES_LSUMMARY], lu[8], sad[8], sk[8], surf[TUBES_LSUMMARY];
    double box[MD], boxc[MD], near[MD], sv, sa, gate;
    int st = tubes_model_info(sys, &ndof, &np, pn, model, pu, pd, sum, lu, box, boxc, sad, near, sk, &si, &sv,
                              &sd, &sa, &gate, surf);
    check("model info status", st == TUBES_OK, st, 0);
    check("rolling_ball has TUBES_NMODEL parameters, 2 dof", np == TUBES_NMODEL && ndof == 2, np, TUBES_NMODEL);
    check("rolling_ball: alpha first, the paper's 0.07", !strcmp(pn, "alpha") && model[0] == 0.07, model[0], 0.07);
    check("rolling_ball: default saddle S12", !strcmp(sad, "S12"), 0, 0);
    double junk[TUBES_MAXPARAM];
    char unknown[TUBES_LSYSTEM] = "no_such_system";   /* the API reads TUBES_LSYSTEM bytes */
    st = tubes_model_info(unknown, &ndof, &np, pn, junk, pu, pd, sum, lu, box, boxc, sad, near, sk, &si,
                          &sv, &sd, &sa, &gate, surf);
    check("unknown system refused", st == TUBES_EINPUT, st, TUBES_EINPUT);
    char nm[TUBES_LSYSTEM];
    int nsys = 0;
    while (tubes_model_system(nsys, nm) == TUBES_OK) nsys++;
    check("six built-in systems (cr3bp_spatial the sixth)", nsys == 6, nsys, 6);
  }
  const double lo[MD] = {-20, -20, 0}, hi[MD] = {20, 20, 0};
  int n = 0, ndof = 0, morse[NMAX], rank1[NMAX];
  double q[MD * NMAX], pp[MD * NMAX], x[NMAX], y[NMAX], h[NMAX], e[NMAX], gn[NMAX], lam[NMAX],
      om[(MD - 1) * NMAX], ev[4 * MD * MD * NMAX];
  char names[8 * NMAX];
  int st = tubes_find_equilibria(sys, model, lo, hi, 41, NMAX, &n, &ndof, q, pp, h, e, gn, morse, rank1, names,
                                 lam, om, ev, NULL);
  {   /* a run's stores: the first call finds and keeps them, the second takes them: the same bits */
    void *stores = tubes_seed_stores_new();
    int n2 = 0, nd2 = 0, m2[NMAX], r2[NMAX], same = 1;
    double q2[MD * NMAX], p2[MD * NMAX], h2[NMAX], e2[NMAX], g2[NMAX], l2[NMAX], o2[(MD - 1) * NMAX],
        v2[4 * MD * MD * NMAX];
    char nm2[8 * NMAX];
    for (int round = 0; round < 2; round++) {
      int s2 = tubes_find_equilibria(sys, model, lo, hi, 41, NMAX, &n2, &nd2, q2, p2, h2, e2, g2, m2, r2, nm2, l2,
                                     o2, v2, stores);
      same = same && s2 == st && n2 == n && !memcmp(q2, q, sizeof(double) * MD * n) &&
             !memcmp(e2, e, sizeof(double) * n) && !memcmp(v2, ev, sizeof(double) * 4 * MD * MD * n);
    }
    check("equilibria kept in a run's stores: the same bits twice", same, n2, n);
    tubes_seed_stores_free(stores);
  }
  for (int k = 0; k < n; k++) {
    x[k] = q[MD * k];
    y[k] = q[MD * k + 1];
  }
  check("equilibria status", st == TUBES_OK, st, TUBES_OK);
  check("nine equilibria", n == 9, n, 9);
  for (int k = 0; k < n; k++) {
    double ek;
    tubes_energy(sys, model, 4, (double[4]){x[k], y[k], 0, 0}, &ek);
    /* energy at rest = g H: the same sum evaluated twice, equal to roundoff */
    check("energy at rest equals g H", fabs(ek - e[k]) <= 1e-12 * fabs(e[k]), ek, e[k]);
    double f[4];
    tubes_vector_field(sys, model, 4, (double[4]){x[k], y[k], 0, 0}, f);
    /* |dp/dt| = g |grad H| <= g * 1e-13 at a converged critical point */
    check("rest point is an equilibrium", fabs(f[2]) + fabs(f[3]) <= 981.0 * 1e-13, fabs(f[2]) + fabs(f[3]), 0);
  }
  int k12 = -1;
  for (int k = 0; k < n; k++)
    if (!strcmp(names + 8 * k, "S12")) k12 = k;
  check("S12 present", k12 >= 0, k12, 0);
  if (k12 >= 0) {
    /* T_po = 2 pi / omega is the small-orbit period; omega^2 = (5/7) g kappa_max */
    double tp = 2 * M_PI / om[(MD - 1) * k12];
    check("T_po in the paper's range (0.7-0.8 s)", tp > 0.7 && tp < 0.8, tp, 0.75);
    /* unstable eigenvector: J u = lambda u with J = [[0, 5/7 I], [-g Hess, 0]]:
       first rows say u_q = (5/7) u_p / lambda */
    const double *u = ev + 4 * MD * MD * k12;   /* the first 16 hold the 4 x 4 matrix */
    double r = fabs(u[0] - 5.0 / 7.0 * u[2] / lam[k12]) + fabs(u[1] - 5.0 / 7.0 * u[3] / lam[k12]);
    check("unstable eigenvector: q part = (5/7) p part / lambda", r < 1e-12, r, 0);
  }
  double p[2];
  tubes_momentum(sys, model, (double[2]){0, 0}, (double[2]){1, 2}, p);
  /* at the origin grad H = (0, 0) by symmetry, so M = I and p = (7/5) v */
  check("momentum at origin", fabs(p[0] - 1.4) < 1e-15 && fabs(p[1] - 2.8) < 1e-15, p[1], 2.8);

  /* trajectory: energy conserved to the tolerance's level; bad input refused */
  enum { NS = 12 };
  double t[NS], s[4 * NS], en[NS], cdamp;
  int64_t cnt[4];
  double ct[8], cx[32];
  int cdir[8], nc = 0;
  int ns = 0;
  st = tubes_run_trajectory(sys, model, 4, (double[4]){4.0, 12.614863819914357, 0, 0}, 1.0, 0.1,
                            TUBES_METHOD_DOP853, 1e-12, 1e-12, 0.0, 1000000, 0.0, 0, 0, 0, 0.0, 0, 0, 0,
                            NS, &ns, t, s, en, &nc, ct, cx, cdir, cnt, &cdamp, NULL, NULL);
  check("trajectory status", st == TUBES_OK, st, 0);
  check("trajectory samples", ns == 11, ns, 11);
  check("energy excess over S12 is 1500", fabs(en[0] - (k12 >= 0 ? e[k12] : 0) - 1500.0) < 1e-8,
        en[0] - (k12 >= 0 ? e[k12] : 0), 1500);
  /* ~100 steps with local error <= 1e-12 relative: drift well below 1e-10 */
  check("energy conserved", fabs(en[ns - 1] - en[0]) <= 1e-10 * en[0], en[ns - 1], en[0]);
  st = tubes_run_trajectory(sys, model, 4, (double[4]){4, 12, 0, 0}, 1.0, -0.1, TUBES_METHOD_DOP853, 1e-12,
                            1e-12, 0.0, 1000, 0.0, 0, 0, 0, 0.0, 0, 0, 0, NS, &ns, t, s, en, &nc, ct, cx,
                            cdir, cnt, &cdamp, NULL, NULL);
  check("negative dt_out refused", st == TUBES_EINPUT, st, TUBES_EINPUT);
  st = tubes_run_trajectory(sys, model, 4, (double[4]){4, 12, 0, 0}, 1.0, 0.1, 99, 1e-12, 1e-12, 0.0, 1000,
                            0.0, 0, 0, 0, 0.0, 0, 0, 0, NS, &ns, t, s, en, &nc, ct, cx, cdir, cnt, &cdamp,
                            NULL, NULL);
  check("unknown method refused", st == TUBES_EINPUT, st, TUBES_EINPUT);
  /* the header's status numbers are the library's (src/base/tubes_status.f90): each one's message */
  static const struct { int code; const char *word; } codes[] = {
      {TUBES_OK, "ok"}, {TUBES_EVENT, "terminal event"}, {TUBES_FULL, "max_crossings"}, {TUBES_EINPUT, "invalid input"},
      {TUBES_EMAXSTEPS, "maximum number of steps"}, {TUBES_ESTEP, "step size underflow"},
      {TUBES_EMODEL, "refused the state"}, {TUBES_EIO, "input/output"}, {TUBES_ENOCONV, "did not converge"},
      {TUBES_EFAULT, "TUBES_FAULT"}, {TUBES_EOUTSIDE, "outside the region"}, {TUBES_ENOCROSS, "no crossing"},
      {TUBES_EPASTEND, "past the end"}, {TUBES_ENARROW, "NHIM's reach"}, {TUBES_ENOJET, "no kernel"},
      {TUBES_EDIRECTION, "other direction first"}, {TUBES_EUNRESOLVED, "below what the energy resolves"},
      {TUBES_ENOREGION, "no bounded region"}, {TUBES_ESHAPE, "star-shaped"},
      {TUBES_EUNDECIDED, "neither passed the gate"}, {TUBES_EDISSIPATIVE, "dissipative"},
      {TUBES_ENOISE, "carries noise"}, {TUBES_EINTERRUPT, "interrupted"}};
  char msg[TUBES_LSTATUS];
  for (size_t i = 0; i < sizeof codes / sizeof codes[0]; i++) {
    tubes_status_message(codes[i].code, msg, sizeof msg);
    check("status number and message as the library's", strstr(msg, codes[i].word) != NULL, codes[i].code, 0);
    check("the message fits TUBES_LSTATUS whole", strlen(msg) < sizeof msg - 1, (double)strlen(msg), 0);
  }
  if (nfail) {
    printf("%d of %d check(s) FAILED in test_capi\n", nfail, nchecks);
    return 1;
  }
  printf("all %d checks passed in test_capi\n", nchecks);
  return 0;
}
