/* Scene drivers (include/tubes_scenes.h). */
#include "tubes_scenes.h"
#include "tubes_record.h"
#include "tubes_h5.h"
#include "tubes_input.h"
#include <float.h>
#include <math.h>
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#ifdef TUBES_MPI
#include <mpi.h>
#endif

/* " <units>" in a message: the rolling ball's units as given, nothing for a dimensionless model
 * (h5_units). */
static const char *in_units(const char *ball_units) {
  return strcmp(h5_units(ball_units), "1") ? ball_units : "";
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* A progress line for one item of a scene's list (an energy): at most one a second, the first
 * always (docs/usage.md); the lines that report a scene's own long step are printed as they come. */
static void progress_item(const char *fmt, ...) {
  static double last = -1e300;
  double t = now();
  if (t - last < 1.0) return;
  last = t;
  va_list ap;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
}

static void status_text(int code, char *buf, int len) { tubes_status_message(code, buf, len); }

/* Does the run's model dissipate (damping_ratio or rolling_resistance > 0; scene_model)? */
static int dissipative(const tubes_run_t *run) { return run->law != NULL; }

/* The dissipation's attributes of a group: dissipation (the law), damping_ratio, damping_rate,
 * rolling_resistance, rolling_drag (those of the laws in use). Returns the write errors. */
static int dissipation_attrs(hid_t g, const tubes_run_t *run) {
  int e = h5_attr_string(g, "dissipation", run->law);
  if (run->zeta > 0) {
    e |= h5_attr_double(g, "damping_ratio", run->zeta);
    e |= h5_attr_double(g, "damping_rate", run->c_damp);
  }
  if (run->crr > 0) {
    e |= h5_attr_double(g, "rolling_resistance", run->crr);
    e |= h5_attr_double(g, "rolling_drag", run->f_roll);
  }
  if (run->noise > 0) e |= h5_attr_double(g, "noise", run->noise);
  if (run->temperature > 0) e |= h5_attr_double(g, "temperature", run->temperature);
  return e;
}

/* The method the run integrates with: &integrator method, and for 'auto' what it became
 * ("auto (taylor)": Taylor for the state, DOP853 for the variational equations; "auto (dop853)":
 * no Taylor kernel). */
static const char *method_label(const tubes_run_t *run) {
  if (strcmp(run->cfg->method, "auto")) return run->cfg->method;
  return run->method == TUBES_METHOD_AUTO ? "auto (taylor)" : "auto (dop853)";
}

enum { NEQ_MAX = 256, MD = TUBES_MAXDOF };
/* The leading-order p_trans, (T_po/A0) dE (1 - tau dE/A0), is flagged where |tau dE/A0| exceeds this. */
#define LEADING_RANGE 0.3
/* The &integrator choice as the C API's arguments (include/tubes.h): every analysis uses it. */
#define INTEGRATOR(c) run->method, (c)->h, (c)->omega_bind, \
                      (strcmp((c)->solver, "fixed_point") ? 1 : 2), (c)->max_iter

/* /model's attributes of a model written as a formula (docs/output.md). */
static int expr_attrs(hid_t g, const tubes_config_t *c) {
  int rc = 0;
  if (!strcmp(c->system, "expression")) {
    rc |= h5_attr_string(g, "formula", c->hamiltonian);
    char buf[TUBES_MAXDOF * (TUBES_LSYM + 2)] = "";
    for (int k = 0; k < TUBES_MAXDOF && c->coordinates[k][0]; k++)
      snprintf(buf + strlen(buf), sizeof buf - strlen(buf), "%s%s", k ? " " : "", c->coordinates[k]);
    rc |= h5_attr_string(g, "coordinates", buf[0] ? buf : "x y");
    buf[0] = 0;
    for (int k = 0; k < TUBES_MAXDOF && c->momenta[k][0]; k++)
      snprintf(buf + strlen(buf), sizeof buf - strlen(buf), "%s%s", k ? " " : "", c->momenta[k]);
    if (!buf[0]) {   /* the default: 'p' + each coordinate (docs/input.md) */
      const char *dq[] = {"x", "y"};
      for (int k = 0; k < TUBES_MAXDOF && (c->coordinates[0][0] ? c->coordinates[k][0] != 0 : k < 2); k++)
        snprintf(buf + strlen(buf), sizeof buf - strlen(buf), "%sp%s", k ? " " : "",
                 c->coordinates[0][0] ? c->coordinates[k] : dq[k]);
    }
    rc |= h5_attr_string(g, "momenta", buf);
  } else {
    rc |= h5_attr_string(g, "formula", c->height);
  }
  static char consts[TUBES_MAXCONST * (TUBES_LCONST + 2)];
  consts[0] = 0;
  for (int k = 0; k < TUBES_MAXCONST; k++)
    if (c->constants[k][0])
      snprintf(consts + strlen(consts), sizeof consts - strlen(consts), "%s%s", consts[0] ? "; " : "", c->constants[k]);
  rc |= h5_attr_string(g, "constants", consts);
  rc |= h5_attr_string(g, "library", c->expr_lib);
  rc |= h5_attr_string(g, "library_name", c->model);
  return rc;
}

int scene_model(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int ndof = 0, np = 0, si = 0, sd = 0;
  static char names[TUBES_MAXPARAM * TUBES_LPARAM], units[TUBES_MAXPARAM * TUBES_LUNITS],
      docs[TUBES_MAXPARAM * TUBES_LDOC];
  char summary[TUBES_LSUMMARY], lu[8], dsad[8], skind[8], surf[TUBES_LSUMMARY];
  double defs[TUBES_MAXPARAM], box[MD], boxc[MD], near[MD], sv, sa, gate;
  if (tubes_model_info(run->system, &ndof, &np, names, defs, units, docs, summary, lu, box, boxc, dsad, near,
                       skind, &si, &sv, &sd, &sa, &gate, surf) < 0)
    return EXIT_BADINPUT;
  hid_t g = h5_group(run->file, "model");
  if (g < 0) return EXIT_IO;
  int rc = 0;
  int formula = !strncmp(c->model, "expr_", 5);   /* a model written as a formula: its library */
  /* a built-in: the library's name (cr3bp with spatial = .true. is cr3bp_spatial) */
  rc |= h5_attr_string(g, "system", formula ? c->system : c->model);
  rc |= h5_attr_string(g, "hamiltonian", summary);
  rc |= h5_attr_long(g, "ndof", ndof);
  if (surf[0]) rc |= h5_attr_string(g, "surface", surf);
  for (int k = 0; k < np; k++) rc |= h5_attr_double(g, names + TUBES_LPARAM * k, run->params[k]);
  if (formula) {
    rc |= expr_attrs(g, c);
    rc |= h5_attr_double(g, "library_seconds", c->expr_seconds);
    rc |= h5_attr_long(g, "library_cached", c->expr_hit);
    printf("model: %s, %d degree%s of freedom%s: %s %.*f %s (%s)\n", summary, ndof, ndof > 1 ? "s" : "",
           run->natural ? ", natural" : "", c->expr_hit ? "generated code loaded from the cache in" :
           "code generated (SymPy) and compiled in", c->expr_hit ? 1 : 2, c->expr_seconds * (c->expr_hit ? 1e3 : 1),
           c->expr_hit ? "ms" : "s", c->expr_lib);
  }
  double zeta = 0, crr = 0, dn = 0, theta = 0;
  for (int k = 0; k < np; k++) {
    if (!strcmp(names + TUBES_LPARAM * k, "damping_ratio")) zeta = run->params[k];
    if (!strcmp(names + TUBES_LPARAM * k, "rolling_resistance")) crr = run->params[k];
    if (!strcmp(names + TUBES_LPARAM * k, "noise")) dn = run->params[k];
    if (!strcmp(names + TUBES_LPARAM * k, "temperature")) theta = run->params[k];
  }
  run->noisy = dn > 0 || theta > 0;
  run->noise = dn;
  run->temperature = theta;
  run->zeta = zeta;    /* the built-in ball's &model damping_ratio, or a formula surface's */
  run->crr = crr;
  run->c_damp = run->f_roll = 0;
  run->dissip[0] = 0;
  run->law = NULL;
  if (zeta > 0 || crr > 0 || run->noisy) {
    int st = tubes_dissipation(run->system, run->params, &run->c_damp, &run->f_roll);
    if (st < 0) {   /* c = 2 zeta omega_1 (and the noise's step) need the lowest well's slow mode */
      if (st == TUBES_EINPUT)
        fprintf(stderr, "%s: &model %s: the model has no well (a minimum of its potential with a positive "
                "frequency) in its search box, and its dissipation is defined by the lowest well's slow mode "
                "omega_1 (docs/dissipation.md#other-models)\n", run->input ? run->input : "tubes",
                zeta > 0 ? "damping_ratio" : (dn > 0 ? "noise" : "temperature"));
      else
        fprintf(stderr, "tubes: &model: the lowest well's slow mode omega_1 (its dissipation's rate) failed, "
                "status %d\n", st);
      H5Gclose(g);
      return st == TUBES_EINPUT ? EXIT_BADINPUT : EXIT_NUMERIC;
    }
    static char law[48];
    snprintf(law, sizeof law, "%s%s%s%s%s", zeta > 0 ? "viscous" : "", zeta > 0 && crr > 0 ? "+" : "",
             crr > 0 ? "rolling" : "", run->noisy && (zeta > 0 || crr > 0) ? "+" : "", run->noisy ? "noise" : "");
    run->law = law;
    if (zeta > 0)
      snprintf(run->dissip, sizeof run->dissip, "damping_ratio = %g, c = %.6g%s", zeta, run->c_damp,
               in_units(" 1/s"));
    if (crr > 0)
      snprintf(run->dissip + strlen(run->dissip), sizeof run->dissip - strlen(run->dissip),
               "%srolling_resistance = %g, f = %.6g%s", zeta > 0 ? "; " : "", crr, run->f_roll, in_units(" cm/s^2"));
    if (run->noisy)
      snprintf(run->dissip + strlen(run->dissip), sizeof run->dissip - strlen(run->dissip), "%s%s = %g%s",
               run->dissip[0] ? "; " : "", dn > 0 ? "noise" : "temperature", dn > 0 ? dn : theta,
               dn > 0 ? in_units(" (cm/s)^2/s") : in_units(" (cm/s)^2"));
    if (zeta > 0) rc |= h5_attr_double(g, "damping_rate", run->c_damp);
    if (crr > 0) rc |= h5_attr_double(g, "rolling_drag", run->f_roll);
    rc |= h5_attr_string(g, "dissipation", run->law);
  }
  H5Gclose(g);
  return rc ? EXIT_IO : 0;
}

/* The equilibria of the model in the run's box (tubes_find_equilibria), arrays of NEQ_MAX. */
typedef struct {
  int n, ndof, morse[NEQ_MAX], rank1[NEQ_MAX];
  double q[MD * NEQ_MAX], p[MD * NEQ_MAX], hgt[NEQ_MAX], en[NEQ_MAX], gn[NEQ_MAX], lam[NEQ_MAX],
      om[(MD - 1) * NEQ_MAX], ev[4 * MD * MD * NEQ_MAX];
  char names[8 * NEQ_MAX];
} eqlist_t;

static int find_eqs(const tubes_run_t *run, eqlist_t *L) {
  return tubes_find_equilibria(run->system, run->params, run->lo, run->hi, run->n_grid, NEQ_MAX, &L->n, &L->ndof,
                               L->q, L->p, L->hgt, L->en, L->gn, L->morse, L->rank1, L->names, L->lam, L->om, L->ev, run->seeds);
}

static int find_named(const eqlist_t *L, const char *name) {
  for (int k = 0; k < L->n; k++)
    if (!strcmp(L->names + 8 * k, name)) return k;
  return -1;
}

/* A message's head: "FILE:LINE: ", or "FILE: " for a value the file does not set (a default: no
 * line), or "tubes: " without a file. */
static void say_at(const tubes_run_t *run, int line) {
  if (run->input && line > 0) fprintf(stderr, "%s:%d: ", run->input, line);
  else if (run->input) fprintf(stderr, "%s: ", run->input);
  else fprintf(stderr, "tubes: ");
}

/* 1 if every scene of the run takes a degenerate saddle (equilibria, flux). */
static int degenerate_ok(const tubes_config_t *c) {
  for (int i = 0; i < TUBES_NSCENES && c->scenes[i][0]; i++)
    if (strcmp(c->scenes[i], "equilibria") && strcmp(c->scenes[i], "flux")) return 0;
  return 1;
}

static double sec_angle(const tubes_config_t *c) { return c->sec_angle * M_PI / 180; }
static int sec_is_ray(const tubes_config_t *c) { return !strcmp(c->sec_kind, "ray"); }

static int scene_asked(const tubes_config_t *c, const char *name) {
  for (int k = 0; k < TUBES_NSCENES; k++)
    if (!strcmp(c->scenes[k], name)) return 1;
  return 0;
}

/* Whether the run needs a saddle: &equilibria saddle or &orbits saddle_near given, or a scene
 * other than equilibria and trajectory. */
static int saddle_asked(const tubes_config_t *c) {
  int need = c->saddle[0] != 0 || c->orb_use_near;
  for (int k = 0; k < TUBES_NSCENES; k++) {
    const char *sc = c->scenes[k];
    need |= sc[0] && strcmp(sc, "equilibria") && strcmp(sc, "trajectory");
  }
  return need;
}

/* The scenes the input asks for make sense for the model: those on a 2-DOF Poincare section
 * (tubes, transition, montecarlo, sections) need 2 degrees of freedom, and a plane section H
 * quadratic in the momenta (its region is {D(p_s) >= 0}, docs/tubes.md); orbits need at least 2.
 * Before any work or output: 0, or EXIT_BADINPUT with the reason. */
static int scenes_apply(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  static const char *on_section[] = {"tubes", "transition", "montecarlo", "sections"};
  const char *sec = NULL;
  char m[1024];
  for (int k = 0; k < TUBES_NSCENES && c->scenes[k][0]; k++) {   /* tubes_setup scene_refused, Python's too */
    int r = tubes_scene_refused(c->scenes[k], run->ndof, !sec_is_ray(c), run->label, m, (int)sizeof m);
    if (r) {
      say_at(run, r == 2 ? run->sec_kind_line : run->scenes_line);
      fprintf(stderr, "%s %s\n", r == 2 ? "&section:" : "&run scenes:", m);
      return EXIT_BADINPUT;
    }
    if (!strcmp(c->scenes[k], "scan") && c->scan_p_trans) {   /* p_trans: the transition scene's rule */
      r = tubes_scene_refused("transition", run->ndof, !sec_is_ray(c), run->label, m, (int)sizeof m);
      if (r) {
        say_at(run, nml_line(run->where, "scan", "p_trans"));
        fprintf(stderr, "&scan p_trans: p_trans is the transition scene's: %s\n", m);
        return EXIT_BADINPUT;
      }
      if (!sec) sec = on_section[1];
    }
    for (int j = 1; j < 4; j++)   /* the scenes on a section's region: their plane is checked below */
      if (!sec && !strcmp(c->scenes[k], on_section[j])) sec = on_section[j];
    if (!sec && !strcmp(c->scenes[k], "tubes") && run->ndof == 2) sec = on_section[0];
  }
  if (sec && !sec_is_ray(c)) {
    int quadratic = 0;
    if (tubes_plane_quadratic(run->system, run->params, c->box_lo, c->box_hi, c->sec_index, c->sec_value,
                              &quadratic) < 0 || !quadratic) {
      say_at(run, run->sec_kind_line);
      fprintf(stderr, "&section kind = 'plane': the plane q%d = %g needs H quadratic in the momenta "
              "(H = 1/2 p^T A(q) p + b(q) . p + V(q), A positive definite: its region on the section is "
              "where a quadratic in p has a root), and H of %s is not, or not defined, along it (checked "
              "over the &equilibria box); the scenes on a section ('%s') cannot be computed for this model\n",
              c->sec_index, c->sec_value, run->label, sec);
      return EXIT_BADINPUT;
    }
  }
  return 0;
}

/* Every dE the scenes ask for is resolvable against the saddle's energy E_e (tubes_de_floor, the
 * library's rule, which its calls also apply: TUBES_EUNRESOLVED), said before any work with the
 * file and line. 0, or EXIT_BADINPUT with the reason. */
/* The scenes' default excess energies and the trajectory's default start are the paper's, in the
 * four-well ball's units and place: any other model (another system, or the ball on a formula
 * surface) sets them, as Python's calls require (tubes._default_de). Before, a formula model ran
 * the ball's 15 energies 1 .. 750 (NaN rows, exit 4) and Henon-Heiles' trajectory started at the
 * ball's (4, 12.6) cm and blew up. des: the excess energies (else the trajectory's start). Checked
 * after the scene and saddle checks, whose messages say more. */
static int defaults_given(const tubes_run_t *run, int des) {
  const tubes_config_t *c = run->cfg;
  if (!strcmp(c->system, "rolling_ball") && strcmp(c->surface, "expression")) return 0;
  int n = 0;
  if (!des) {
    if (scene_asked(c, "trajectory") && !nml_line(run->where, "trajectory", "x0") &&
        !nml_line(run->where, "trajectory", "y0")) {
      say_at(run, nml_line(run->where, "run", "scenes"));
      fprintf(stderr, "&trajectory: x0, y0 are not set: system %s has no default start (the default, (4, "
              "12.614863819914357) cm, is on the four-well ball's surface); give x0, y0 (and px0, py0 or at_rest) "
              "in the model's units (docs/input.md)\n", run->label);
      n++;
    }
    return n ? EXIT_BADINPUT : 0;
  }
  static const char *groups[] = {"orbits", "tubes", "transition", "montecarlo", "sections", "flux"};
  for (size_t k = 0; k < sizeof groups / sizeof groups[0]; k++) {
    const char *g = groups[k];
    if (!scene_asked(c, g) || nml_line(run->where, g, "de")) continue;
    if (!strcmp(g, "flux") && nml_line(run->where, "transition", "de")) continue;   /* &flux de defaults to it */
    if (!strcmp(g, "orbits") && c->orb_njacobi + c->orb_nperiods > 0) continue;   /* by C or period instead */
    const char *def = "?";
    for (int j = 0; j < tubes_nml_nvars; j++)
      if (!strcmp(tubes_nml_vars[j].group, g) && !strcmp(tubes_nml_vars[j].name, "de")) def = tubes_nml_vars[j].deflt;
    say_at(run, nml_line(run->where, "run", "scenes"));
    fprintf(stderr, "&%s: de is not set: system %s has no default excess energies (the default, %s, is the four-well "
            "ball's, in (cm/s)^2); give de in the model's energy units for the scene '%s' (docs/input.md)\n", g,
            run->label, def, g);
    n++;
  }
  return n ? EXIT_BADINPUT : 0;
}

static int de_resolvable(const tubes_run_t *run, double ee) {
  const tubes_config_t *c = run->cfg;
  if (defaults_given(run, 1)) return EXIT_BADINPUT;
  const struct { const char *scene, *group; const double *de; int n; } lists[] = {
      {"orbits", "orbits", c->orb_de, c->orb_njacobi + c->orb_nperiods > 0 ? 0 : c->orb_nde},
      {"tubes", "tubes", c->tub_de, c->tub_nde},
      {"transition", "transition", c->tra_de, c->tra_nde}, {"montecarlo", "montecarlo", &c->mc_de, 1},
      {"sections", "sections", c->pm_de, c->pm_nde},    {"flux", "flux", c->flux_de, c->flux_nde}};
  double need = tubes_de_floor(ee), res = need / 1e6;
  for (size_t j = 0; j < sizeof lists / sizeof lists[0]; j++) {
    if (!scene_asked(c, lists[j].scene)) continue;
    for (int i = 0; i < lists[j].n; i++)
      if (fabs(lists[j].de[i]) < need) {
        say_at(run, nml_line(run->where, lists[j].group, "de"));
        fprintf(stderr, "&%s de = %g: below what the energy resolves at the saddle %s: E_e = %.10g is "
                "known to about %.2g (16 ulps), and E_e + dE only to a relative %.2g of dE; dE must be at least %.3g "
                "(16 ulps a millionth of it), or H's additive constant smaller (a large constant term: the ball's h0)\n",
                lists[j].group, lists[j].de[i], run->saddle, ee, res, res / fabs(lists[j].de[i]), need);
        return EXIT_BADINPUT;
      }
  }
  return 0;
}

int run_setup(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int np = 0, si = 0, sd = 0;
  static char names[TUBES_MAXPARAM * TUBES_LPARAM], units[TUBES_MAXPARAM * TUBES_LUNITS],
      docs[TUBES_MAXPARAM * TUBES_LDOC];
  char summary[TUBES_LSUMMARY], lu[8], dsad[8], skind[8], surf[TUBES_LSUMMARY];
  double defs[TUBES_MAXPARAM], box[MD], boxc[MD], near[MD], sv, sa, gate;
  memset(run->system, 0, sizeof run->system);
  tubes_progress_enable(1);   /* the ensembles' progress lines (src/base/tubes_progress_shim.c) */
  snprintf(run->system, sizeof run->system, "%s", c->model);   /* the library's name of the model */
  int formula = !strncmp(c->model, "expr_", 5);
  snprintf(run->label, sizeof run->label, "%s%s", formula ? c->system : c->model,
           formula && strcmp(c->system, "expression") ? " (surface 'expression')" : "");
  if (tubes_model_info(run->system, &run->ndof, &np, names, defs, units, docs, summary, lu, box, boxc, dsad, near,
                       skind, &si, &sv, &sd, &sa, &gate, surf) < 0) {
    fprintf(stderr, "tubes: unknown system '%s'\n", c->system);
    return EXIT_BADINPUT;
  }
  for (int k = 0; k < TUBES_MAXPARAM; k++) run->params[k] = k < c->nparams ? c->params[k] : 0;
  snprintf(run->length_units, sizeof run->length_units, "%s", lu);
  if (tubes_model_natural(run->system, run->params, &run->natural) < 0) {
    fprintf(stderr, "tubes: &model: the parameters are out of range for system %s\n", run->label);
    return EXIT_BADINPUT;
  }
  int rc = scenes_apply(run);
  if (rc) return rc;
  if ((rc = defaults_given(run, 0))) return rc;
  run->method = tubes_method_code(c->method);
  int integrates = 0;                /* a scene that integrates with &integrator's method */
  for (int k = 0; k < TUBES_NSCENES; k++)
    integrates |= c->scenes[k][0] && strcmp(c->scenes[k], "equilibria");
  if (integrates && (run->method == TUBES_METHOD_TAYLOR || run->method == TUBES_METHOD_AUTO)) {   /* the kernel, before output */
    char m[1024];
    if (tubes_taylor_check(run->system, run->params, c->rtol, m, (int)sizeof m) < 0) {
      if (run->method == TUBES_METHOD_TAYLOR) {
        say_at(run, run->method_line);
        fprintf(stderr, "&integrator: method = 'taylor': no Taylor kernel for %s: %s\n", run->label, m);
        return EXIT_BADINPUT;
      }
      if (run->rank == 0)
        fprintf(stderr, "tubes: &integrator method = 'auto': DOP853 throughout (no Taylor kernel for %s: %s)\n",
                run->label, m);
      run->method = TUBES_METHOD_DOP853;
    }
  }
  for (int k = 0; k < MD; k++) {
    run->lo[k] = c->box_lo[k];
    run->hi[k] = c->box_hi[k];
  }
  run->n_grid = c->n_grid;
  memset(run->saddle, 0, sizeof run->saddle);
  snprintf(run->saddle, sizeof run->saddle, "%s", c->orb_saddle);
  /* the saddle: needed by every scene but equilibria and trajectory; checked here, once */
  if (!saddle_asked(c)) return 0;
  static eqlist_t L;
  int st = find_eqs(run, &L);
  if (st < 0) {
    char m[TUBES_LSTATUS];
    status_text(st, m, sizeof m);
    fprintf(stderr, "tubes: the equilibria of %s in the &equilibria box could not be found: %s (status %d)%s\n",
            run->label, m, st, st == TUBES_ENOCONV ? "; or the box holds more than 256 of them: a smaller box" : "");
    return EXIT_NUMERIC;
  }
  /* the saddle by name, or the nearest to saddle_near (tubes_setup choose_saddle, Python's too) */
  int kinds[NEQ_MAX], k;
  char m[2048];
  for (int j = 0; j < L.n; j++) kinds[j] = L.rank1[j] == 1 ? 1 : L.rank1[j] == 2 ? 2 : 0;
  if (c->saddle[0] &&                /* &equilibria saddle: the saddle the equilibria scene reports */
      tubes_choose_saddle(L.n, L.names, kinds, MD, L.ndof, L.q, c->saddle, 0, c->orb_saddle_near, degenerate_ok(c),
                          run->label, 0, &k, m, (int)sizeof m)) {
    say_at(run, run->eq_saddle_line);
    fprintf(stderr, "&equilibria: %s\n", m);
    return EXIT_BADINPUT;
  }
  if (tubes_choose_saddle(L.n, L.names, kinds, MD, L.ndof, L.q, run->saddle, c->orb_use_near, c->orb_saddle_near,
                          degenerate_ok(c), run->label, !c->orb_use_near && !run->orb_saddle_line, &k, m,
                          (int)sizeof m)) {
    int ln = c->orb_use_near ? nml_line(run->where, "orbits", "saddle_near") : run->orb_saddle_line;
    say_at(run, ln);
    if (c->orb_use_near) fprintf(stderr, "&orbits saddle_near%s: %s\n", ln ? "" : " (the system's default)", m);
    else fprintf(stderr, "&orbits: %s\n", m);
    return EXIT_BADINPUT;
  }
  snprintf(run->saddle, sizeof run->saddle, "%s", L.names + 8 * k);
  return de_resolvable(run, L.en[k]);
}

/* The equilibria scene: src/workflow/tubes_scene_equilibria.f90 (its record written by
 * record_emit); with dissipation, /saddle takes the dissipation's attributes. */
int scene_equilibria(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_equilibria_scene(run->system, run->params, run->lo, run->hi, run->n_grid, c->box,
                                 c->saddle[0] ? c->saddle : run->saddle, saddle_asked(c), run->label,
                                 dissipative(run) ? run->dissip : "", run->seeds);
  int rc = record_emit(run->file, h);
  if (rc || !dissipative(run) || H5Lexists(run->file, "saddle", H5P_DEFAULT) <= 0) return rc;
  hid_t g = H5Gopen2(run->file, "saddle", H5P_DEFAULT);
  if (g < 0) return EXIT_IO;
  rc = dissipation_attrs(g, run);
  H5Gclose(g);
  return rc ? EXIT_IO : 0;
}

int scene_trajectory(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  double x0[4] = {c->x0, c->y0, c->px0, c->py0};
  int h = tubes_trajectory_scene(run->system, run->params, x0, c->at_rest, c->t_end, c->dt_out, c->section,
                                 c->section_direction, c->section_angle, c->section_level, c->stop_at_first,
                                 c->max_crossings, run->method, method_label(run), c->rtol, c->atol, c->h,
                                 (long long)c->max_steps, c->omega_bind, strcmp(c->solver, "fixed_point") ? 1 : 2,
                                 c->solver, c->max_iter, run->zeta, run->crr, run->f_roll,
                                 dissipative(run) ? run->dissip : "", run->lo, run->hi, run->n_grid, run->label,
                                 run->input ? run->input : "tubes", in_units(" s"), in_units(" (cm/s)^2"), run->seeds);
  return record_emit(run->file, h);
}

static const char *end_reason_text(int r) {
  switch (r) {
  case 1: return "the orbits run into another equilibrium";
  case 2: return "the period grows without bound";
  case 3: return "the correction fails for ever smaller steps";
  case 4: return "the branch's energy turns back (a fold)";
  case 5: return "the family has no branch point below the largest dE";
  case 6: return "the continuation took its 2000 steps";
  case 7: return "past a fold the energy returned to the start's";
  case 8: return "the guess did not converge";
  case 9: return "no requested energy lies on the branch's side of the bifurcation";
  case 10: return "the arc closed into a loop (a fold at its start's energy; the energies not taken are not on it)";
  case 11: return "the saddle's centre modes do not define the family by this name";
  default: return "none";
  }
}

/* Why the family has no orbit at de (the continuation ended, at end_de if > 0, for reason): past
 * the family's end, or short of its extrapolated end (the continuation stopped before de). */
static void family_stop_text(const tubes_run_t *run, double de, double end_de, int reason, char *buf, size_t len) {
  if (end_de > 0 && de >= end_de * (1 - 1e-6))
    snprintf(buf, len, "dE = %g is past the end of the %s family, which ends at dE ~ %.8g%s (%s): no orbit there", de,
             run->saddle, end_de, in_units(" (cm/s)^2"), end_reason_text(reason));
  else if (end_de > 0)
    snprintf(buf, len, "dE = %g was not reached: the continuation of the %s family stopped before it (%s%s); the "
             "family's end, extrapolated from its last orbits, is at dE ~ %.8g%s, beyond this dE: an orbit may exist "
             "there that the continuation does not reach", de, run->saddle, end_reason_text(reason),
             reason == 2 ? ": it passed the continuation's limit on the period" : "", end_de, in_units(" (cm/s)^2"));
  else
    snprintf(buf, len, "dE = %g is past the end of the %s family: no orbit there", de, run->saddle);
}

/* The dE of the orbits asked for by &orbits jacobi (pkind 1) or periods (2) (docs/orbits.md, "Orbits by
 * Jacobi constant or period"; tubes_orbit_by_parameter) into *des (n, malloc'd): 0, or the exit code with
 * the message: EXIT_BADINPUT for a value with no orbit of the family by its nature (C at or above the
 * saddle's, dE not increasing along the list), EXIT_PARTIAL for a period the family does not reach
 * or one the root finder could not locate, EXIT_NUMERIC when the family could not be set up. */
static int orbit_parameter_des(tubes_run_t *run, int pkind, int n, int nseg, double **des) {
  const tubes_config_t *c = run->cfg;
  const double *val = pkind == 1 ? c->orb_jacobi : c->orb_periods;
  const char *name = pkind == 1 ? "jacobi" : "periods";
  double *d = calloc(n, sizeof(double));
  int *found = calloc(n, sizeof(int));
  double t_po = 0, t_reach = 0, de_reach = 0, e_sad = 0, t0 = now();
  int rc = 0;
  *des = NULL;
  if (!d || !found) {
    fprintf(stderr, "tubes: orbits: out of memory\n");
    free(d); free(found);
    return EXIT_NUMERIC;
  }
  if (pkind == 2)
    fprintf(stderr, "orbits: locating the %s family's orbits of the %d period%s (Brent on T(dE))...\n", run->saddle,
            n, n > 1 ? "s" : "");
  int st = tubes_orbit_by_parameter(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, pkind, n, val,
                                 nseg, c->orb_family, c->orb_tol, c->orb_rtol, c->orb_atol, c->orb_max_iter,
                                 c->orb_n_samples, INTEGRATOR(c), 0, run->seeds, c->orb_nguess, c->orb_guess,
                                 c->orb_period, d, found, &t_po, &t_reach, &de_reach, &e_sad);
  if (st < 0) {
    char m[TUBES_LSTATUS];
    status_text(st, m, sizeof m);
    fprintf(stderr, "tubes: orbits: &orbits %s: the family's orbits could not be located: %s (status %d)\n", name,
            m, st);
    free(d); free(found);
    return st == TUBES_EINPUT ? EXIT_BADINPUT : EXIT_NUMERIC;
  }
  int guessed = c->orb_nguess > 0 || c->orb_family <= -101;   /* a guess's family or a branch: any dE */
  double c_sad = 0;                                             /* the saddle's Jacobi constant (the model's) */
  if (pkind == 1) tubes_jacobi_constant(run->system, run->params, 1, &e_sad, &c_sad);
  for (int k = 0; k < n && !rc; k++) {
    if (found[k] == 3) {
      fprintf(stderr, "tubes: orbits: &orbits jacobi: system '%s' has no Jacobi constant (give de)\n", c->system);
      rc = EXIT_BADINPUT;
    } else if (found[k] == 1) {
      fprintf(stderr, "tubes: orbits: &orbits periods(%d) = %.12g: not reached: the %s family's period runs from "
              "T_po = 2 pi/omega = %.12g at the saddle to %.12g (at dE = %.10g, where the search along the family "
              "ended) without taking this value; no orbit computed\n", k + 1, val[k], run->saddle, t_po, t_reach,
              de_reach);
      rc = EXIT_PARTIAL;
    } else if (found[k] == 2) {
      fprintf(stderr, "tubes: orbits: &orbits periods(%d) = %.12g: the root finder on T(dE) did not locate it to "
              "1e-12 of the period (the orbits inside the bracket did not converge); no orbit computed\n", k + 1,
              val[k]);
      rc = EXIT_PARTIAL;
    } else if (!guessed && !(d[k] > 0)) {
      fprintf(stderr, "tubes: orbits: &orbits jacobi(%d) = %.12g is not below the saddle %s's C = %.12g: no orbit of "
              "its Lyapunov family there (allowed: C < %.12g: the orbits' dE = E(C) - E_e > 0)\n", k + 1, val[k],
              run->saddle, c_sad, c_sad);
      rc = EXIT_BADINPUT;
    } else if (k > 0 && !(d[k] > d[k - 1])) {
      fprintf(stderr, "tubes: orbits: &orbits %s(%d) = %.12g: its orbit (dE = %.12g) lies below the previous one's "
              "(dE = %.12g): give the %s in the order the family reaches them (dE increasing)\n", name, k + 1, val[k],
              d[k], d[k - 1], name);
      rc = EXIT_BADINPUT;
    }
  }
  if (rc) {
    free(d); free(found);
    return rc;
  }
  if (pkind == 2) {
    printf("orbits: by period: T_po = 2 pi/omega = %.12g at the saddle; the first crossing of each period from the "
           "saddle, Brent on T(dE) to |T - T*| <= 1e-12 T* (%.2f s)\n", t_po, now() - t0);
    for (int k = 0; k < n; k++) printf("  period %.12g -> dE = %.15g\n", val[k], d[k]);
  } else {
    printf("orbits: by Jacobi constant (saddle %s: C = %.12g)\n", run->saddle, c_sad);
    for (int k = 0; k < n; k++) printf("  C = %.12g -> dE = %.15g\n", val[k], d[k]);
  }
  free(found);
  *des = d;
  return 0;
}

int scene_orbits(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  /* the orbits asked for by Jacobi constant or period (orbit_parameter_des): a copy of the settings
   * whose orb_de holds their dE, the scene's as with de */
  int pkind = c->orb_njacobi > 0 ? 1 : c->orb_nperiods > 0 ? 2 : 0;
  tubes_config_t *cp = NULL;
  if (pkind) {
    double *dp = NULL;
    int np = pkind == 1 ? c->orb_njacobi : c->orb_nperiods;
    int prc = orbit_parameter_des(run, pkind, np, strcmp(c->orb_method, "multiple") ? 1 : c->orb_n_segments, &dp);
    if (prc) return prc;
    cp = malloc(sizeof *cp);
    if (!cp) { free(dp); fprintf(stderr, "tubes: orbits: out of memory\n"); return EXIT_NUMERIC; }
    *cp = *c;
    memcpy(cp->orb_de, dp, sizeof(double) * np);
    cp->orb_nde = np;
    free(dp);
    c = cp;
  }
  int n = c->orb_nde, ns = c->orb_n_samples, mi = c->orb_max_iter;
  int nseg = strcmp(c->orb_method, "multiple") ? 1 : c->orb_n_segments;
  /* the Jacobi constant of each orbit, for a model that defines one (the CR3BP) */
  double *jac = calloc(n, sizeof(double));
  int has_jacobi = 0;
  if (jac) {
    double z = 0, cz = 0;
    has_jacobi = tubes_jacobi_constant(run->system, run->params, 1, &z, &cz) >= 0;
  }
  double *e = calloc(n, sizeof(double)), *per = calloc(n, sizeof(double)), *act = calloc(n, sizeof(double)),
         *s0 = calloc(6 * n, sizeof(double)), *mu = calloc(n, sizeof(double)), *ms = calloc(n, sizeof(double)),
         *mt = calloc(4 * n, sizeof(double)), *stab = calloc(n, sizeof(double)), *res = calloc(n, sizeof(double)),
         *clo = calloc(n, sizeof(double)), *md = calloc(n, sizeof(double)), *mono = calloc(36 * n, sizeof(double)),
         *ts = calloc((size_t)ns * n, sizeof(double)), *xs = calloc((size_t)6 * ns * n, sizeof(double)),
         *hist = calloc((size_t)mi * n, sizeof(double));
  int *it = calloc(n, sizeof(int)), *conv = calloc(n, sizeof(int));
  int rc = 0;
  if (!e || !per || !act || !s0 || !mu || !ms || !mt || !stab || !res || !clo || !md || !mono || !ts || !xs ||
      !hist || !it || !conv) {
    fprintf(stderr, "tubes: orbits: out of memory\n");
    rc = EXIT_NUMERIC;
    goto out;
  }
  double end_de = -1, t0 = now();
  int reason = 0;
  fprintf(stderr, "orbits: continuing the %s family to dE = %g (%s shooting)...\n", run->saddle,
          c->orb_de[n - 1], nseg > 1 ? "multiple" : "single");
  int st = tubes_orbit_family(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, n, c->orb_de, nseg, c->orb_family, c->orb_tol, c->orb_rtol,
                              c->orb_atol, mi, ns, INTEGRATOR(c), e, per, act, s0, mu, ms, mt, stab, res, clo, it, conv, md,
                              mono, ts, xs, hist, &end_de, &reason, 0, run->seeds, c->orb_nguess, c->orb_guess,
                              c->orb_period);
  if (st < 0) {
    char m[TUBES_LSTATUS];
    status_text(st, m, sizeof m);
    fprintf(stderr, "tubes: orbits: failed: %s (status %d)\n", m, st);
    rc = EXIT_NUMERIC;
    goto out;
  }
  const char *famname = c->orb_family == -1 ? "halo_north" : c->orb_family == -2 ? "halo_south" : "Lyapunov";
  if (c->orb_family == -3) famname = "vertical";
  else if (c->orb_family == -4) famname = "lyapunov";
  else if (c->orb_family == -5) famname = "axial";
  char fambuf[32];
  /* a guess's family or a branch by the general arc ('branch:K', 'axial'): any dE */
  int guessed = c->orb_nguess > 0 || c->orb_family <= -101 || c->orb_family == -5;
  if (c->orb_family <= -101) {
    snprintf(fambuf, sizeof fambuf, "branch:%d", -100 - c->orb_family);
    famname = fambuf;
  } else if (c->orb_nguess > 0) famname = "guess";
  printf("orbits: %s %s family, %s shooting%s%s (%.2f s)\n", run->saddle, famname, nseg > 1 ? "multiple" : "single",
         guessed ? " (no symmetry assumed; continued in arclength)" : nseg > 1 ? "" : (run->natural ? " (brake orbit)" : " (symmetric orbit)"),
         dissipative(run) ? ", of the conservative model (a dissipative model has no periodic orbits: they are the limit "
                         "the damped model's transition regions start from)" : "", now() - t0);
  if (has_jacobi) tubes_jacobi_constant(run->system, run->params, n, e, jac);   /* C of E = E_e + dE */
  printf("  %10s %12s %14s %14s %11s %9s %5s%s\n", "dE", strcmp(in_units(" s"), "") ? "period [s]" : "period", "action",
         "mu_unstable", "residual", "closure", "iter", has_jacobi ? "        C (Jacobi)" : "");
  int nfail = 0;
  for (int k = 0; k < n; k++) {
    if (conv[k])
    {
      printf("  %10.4g %12.9f %14.8g %14.8g %11.2e %9.1e %5d", c->orb_de[k], per[k], act[k], mu[k], res[k],
             clo[k], it[k]);
      if (has_jacobi) printf(" %17.12f", jac[k]);
      putchar('\n');
    }
    else {
      nfail++;
      if (!guessed && end_de > 0 && c->orb_de[k] >= end_de * (1 - 1e-6))
        printf("  %10.4g   refused: past the end of the family (dE ~ %.6g)\n", c->orb_de[k], end_de);
      else if (guessed && it[k] == 0)
        printf("  %10.4g   not reached (the family stop below)\n", c->orb_de[k]);
      else
        printf("  %10.4g   not converged\n", c->orb_de[k]);
    }
  }
  if (guessed) {
    /* a guess's family or a branch (docs/orbits.md, "Orbits from a guess"): the arc's stopping rule */
    if (reason == 8) {
      fprintf(stderr, "tubes: orbits: &orbits guess = (");
      for (int i = 0; i < c->orb_nguess; i++) fprintf(stderr, "%s%.10g", i ? ", " : "", c->orb_guess[i]);
      fprintf(stderr, "), period = %g: the guess did not converge to a periodic orbit (multiple shooting at the "
              "guess's own energy, %d segment%s); no orbit computed: give a state and period closer to a periodic "
              "orbit\n", c->orb_period, nseg, nseg > 1 ? "s" : "");
      rc = EXIT_BADINPUT;
    } else if (reason == 5 && c->orb_family == -5) {
      fprintf(stderr, "tubes: orbits: family = 'axial': the %s's planar Lyapunov family ('lyapunov') has no branch "
              "point with a tangent odd under the reversor (the axial one) below dE = %g; not computed\n",
              run->saddle, c->orb_de[n - 1]);
    } else if (reason == 5) {
      fprintf(stderr, "tubes: orbits: family = '%s': the parent family has no branch point or period doubling as "
              "its bifurcation %d between the requested energies (/orbits/bifurcations of the run without it); not "
              "computed\n", famname, -100 - c->orb_family);
    }
    printf("  family stop: %s", end_reason_text(reason));
    if (reason && reason != 5 && reason != 8 && reason != 11) printf(" (at dE = %.10g)", end_de);
    putchar('\n');
    for (int k = 0; k < n; k++)
      if (!conv[k] && reason != 8 && reason != 5 && reason != 11)
        fprintf(stderr, "tubes: orbits: dE = %g: no %s orbit: %s\n", c->orb_de[k], famname,
                reason == 9 || reason == 0 ? "not on this side of the start (each energy is taken where the "
                "continuation first crosses it)" : end_reason_text(reason));
  } else if (reason == 11) {
    /* handled below with the axial family's (a family by name the saddle's modes do not define) */
  } else if (c->orb_family < 0 && reason == 5) {
    printf("  no %s family: %s (dE = %g)\n", famname, end_reason_text(reason), c->orb_de[n - 1]);
    fprintf(stderr, "tubes: orbits: no %s orbits: the %s's family %d (its planar Lyapunov family in the CR3BP) has no "
            "branch point below dE = %g; not computed\n", famname, run->saddle, run->ndof - 1, c->orb_de[n - 1]);
  } else if (c->orb_family < 0 && nfail && end_de <= 0) {
    for (int k = 0; k < n; k++)
      if (!conv[k])
        fprintf(stderr, "tubes: orbits: dE = %g: no %s orbit: below the branch point (the branch starts at the "
                "energy of the planar family's first branch point, /orbits/bifurcations of that family)\n",
                c->orb_de[k], famname);
  } else if (end_de > 0) {
    printf("  family end: dE ~ %.8g%s: %s\n", end_de, in_units(" (cm/s)^2"), end_reason_text(reason));
    for (int k = 0; k < n; k++)
      if (!conv[k]) {
        char m[512];
        family_stop_text(run, c->orb_de[k], end_de, reason, m, sizeof m);
        fprintf(stderr, "tubes: orbits: %s; not computed\n", m);
      }
  } else {
    for (int k = 0; k < n; k++)
      if (!conv[k]) {
        fprintf(stderr, "tubes: orbits: dE = %g: the correction did not converge; residual history:", c->orb_de[k]);
        for (int j = 0; j < it[k] && j < mi; j++) fprintf(stderr, " %.2e", hist[(size_t)k * mi + j]);
        fputc('\n', stderr);
      }
  }
  if (reason == 11) {   /* END_NOMODE: 'vertical', 'lyapunov' or 'axial' where the modes do not define it */
    fprintf(stderr, "tubes: orbits: family = '%s': no centre mode of the %s of system '%s' lies out of the plane "
            "(an eigenvector with all its weight on q%d, p%d) beside a planar one, so the %s family is not defined "
            "here (allowed: family = 1 .. %d by number, docs/orbits.md \"Branch switching\")\n", famname, run->saddle,
            c->system, run->ndof, run->ndof, famname, run->ndof > 1 ? run->ndof - 1 : 1);
    rc = EXIT_BADINPUT;
  }
  /* the integration's own accuracy (tubes_verdicts orbit_coarse, Python's orbit_family's too) */
  for (int k = 0; k < n; k++) {
    if (!conv[k]) continue;
    double scale = 0;
    char m[1024];
    for (int i = 0; i < 2 * run->ndof; i++) scale = fmax(scale, fabs(s0[6 * k + i]));
    if (tubes_verdict_orbit_coarse(c->orb_de[k], clo[k], mu[k], scale, m, (int)sizeof m)) {
      fprintf(stderr, "%s\n", m);
      rc = EXIT_NUMERIC;
    }
  }
  /* bifurcation monitoring (docs/orbits.md, "Bifurcations"): the Floquet indices of each orbit and
   * the bifurcations located between them, on the family the run's stores hold */
  enum { MAXBIF = 64 };
  int nbif = 0, bkind[MAXBIF], bafter[MAXBIF], bconv[MAXBIF];
  double bde[MAXBIF], bwid[MAXBIF], ben[MAXBIF], bper[MAXBIF], bnu[4 * MAXBIF], bx0[6 * MAXBIF], btan[6 * MAXBIF];
  double *nu = calloc(4 * (size_t)n, sizeof(double));
  if (!nu) { fprintf(stderr, "tubes: orbits: out of memory\n"); rc = EXIT_NUMERIC; goto out; }
  double tb = now(), btol = 0;
  int sb = tubes_orbit_bifurcations(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, n, c->orb_de,
                                    nseg, c->orb_family, c->orb_tol, c->orb_rtol, c->orb_atol, mi, ns, INTEGRATOR(c),
                                    nu, MAXBIF, &nbif, bkind, bafter, bde, bwid, ben, bper, bnu, bconv, bx0, btan, &btol, 0,
                                    run->seeds, c->orb_nguess, c->orb_guess, c->orb_period);
  if (sb < 0) {
    char m[TUBES_LSTATUS];
    status_text(sb, m, sizeof m);
    fprintf(stderr, "tubes: orbits: bifurcation monitoring failed: %s (status %d)\n", m, sb);
    free(nu);
    rc = EXIT_NUMERIC;
    goto out;
  }
  if (nbif > MAXBIF) {
    fprintf(stderr, "tubes: orbits: %d bifurcations between the requested energies; the first %d are kept: ask for "
            "fewer dE at a time\n", nbif, MAXBIF);
    nbif = MAXBIF;
    if (!rc) rc = EXIT_PARTIAL;
  }
  static const char *bif_name[] = {"", "branch_point", "period_doubling", "krein_collision", "fold"};
  int np = run->ndof - 1;
  if (c->orb_family < 0 && c->orb_family != -3 && c->orb_family != -4)
    printf("  bifurcations: not located along a branch family (its orbits' Floquet indices are written)\n");
  else if (nbif == 0)
    printf("  bifurcations: none between the requested energies (Floquet indices: %d pair%s)\n", np, np > 1 ? "s" : "");
  else {
    printf("  bifurcations (located by bisection to a bracket of %.0e dE; %.2f s):\n", btol, now() - tb);
    printf("  %-16s %18s %11s %18s %14s  %s\n", "kind", "dE", "bracket", "energy", "period", "Floquet indices (nu)");
    for (int j = 0; j < nbif; j++) {
      if (!bconv[j]) {
        printf("  %-16s %18.12g %11.2e   the corrector failed inside the bracket\n", bif_name[bkind[j]], bde[j], bwid[j]);
        fprintf(stderr, "tubes: orbits: the %s between dE = %g and %g: the corrector failed inside the bisection's "
                "bracket [%.12g +- %.2g]; not located further\n", bif_name[bkind[j]], c->orb_de[bafter[j]],
                c->orb_de[bafter[j] + 1], bde[j], bwid[j] / 2);
        if (!rc) rc = EXIT_PARTIAL;
        continue;
      }
      printf("  %-16s %18.12g %11.2e %18.12f %14.10f ", bif_name[bkind[j]], bde[j], bwid[j], ben[j], bper[j]);
      for (int i = 0; i < np; i++)
        if (bnu[4 * j + 2 + i] != 0) printf(" %.10g%+.3gi", bnu[4 * j + i], bnu[4 * j + 2 + i]);
        else printf(" %.10g", bnu[4 * j + i]);
      putchar('\n');
    }
  }
  hid_t g = h5_group(run->file, "orbits");
  if (g < 0) { free(nu); rc = EXIT_IO; goto out; }
  int n2 = 2 * run->ndof;   /* state components: 2N */
  hsize_t dn = (hsize_t)n, d4[2] = {(hsize_t)n, (hsize_t)n2}, d2[2] = {(hsize_t)n, 2},
          d44[3] = {(hsize_t)n, (hsize_t)n2, (hsize_t)n2};
  double *mre = malloc(sizeof(double) * 2 * n), *mim = malloc(sizeof(double) * 2 * n),
         *monot = malloc(sizeof(double) * 36 * n);
  for (int k = 0; k < n; k++) {
    mre[2 * k] = mt[4 * k]; mim[2 * k] = mt[4 * k + 1]; mre[2 * k + 1] = mt[4 * k + 2]; mim[2 * k + 1] = mt[4 * k + 3];
    for (int i = 0; i < n2; i++)
      for (int j = 0; j < n2; j++) monot[n2 * n2 * k + n2 * i + j] = mono[36 * k + n2 * j + i];   /* row-major */
    for (int i = 0; i < n2; i++) s0[n2 * k + i] = s0[6 * k + i];                                /* compact */
    for (int j = 0; j < ns; j++)
      for (int i = 0; i < n2; i++) xs[(size_t)n2 * (k * ns + j) + i] = xs[(size_t)6 * (k * ns + j) + i];
  }
  int h = 0;
  h |= h5_write_double(g, "dE", 1, &dn, c->orb_de, NULL);
  h |= h5_write_double(g, "energy", 1, &dn, e, NULL);
  if (has_jacobi) h |= h5_write_double(g, "jacobi", 1, &dn, jac, NULL);
  if (pkind) {
    h |= h5_attr_string(g, "parameter", pkind == 1 ? "jacobi" : "periods");
    h |= h5_write_double(g, pkind == 1 ? "requested_jacobi" : "requested_period", 1, &dn,
                         pkind == 1 ? c->orb_jacobi : c->orb_periods, NULL);
  }
  h |= h5_write_double(g, "period", 1, &dn, per, NULL);
  h |= h5_write_double(g, "action", 1, &dn, act, NULL);
  h |= h5_write_double(g, "mu_unstable", 1, &dn, mu, NULL);
  h |= h5_write_double(g, "mu_stable", 1, &dn, ms, NULL);
  h |= h5_write_double(g, "mu_trivial", 2, d2, mre, NULL);
  h |= h5_write_double(g, "mu_trivial_imag", 2, d2, mim, NULL);
  h |= h5_write_double(g, "stability_index", 1, &dn, stab, NULL);
  h |= h5_write_double(g, "state0", 2, d4, s0, n2 == 4 ? "cm, cm, cm/s, cm/s" : "state units");
  h |= h5_write_int(g, "converged", dn, conv, NULL);
  h |= h5_write_double(g, "residual", 1, &dn, res, NULL);
  h |= h5_write_double(g, "closure", 1, &dn, clo, NULL);
  h |= h5_write_int(g, "iterations", dn, it, NULL);
  h |= h5_write_double(g, "min_eq_distance", 1, &dn, md, NULL);
  h |= h5_write_double(g, "monodromy", 3, d44, monot, NULL);
  h |= h5_attr_string(g, "saddle", run->saddle);
  h |= h5_attr_string(g, "method", nseg > 1 ? "multiple" : "single");
  h |= h5_attr_long(g, "n_segments", nseg);
  h |= h5_attr_double(g, "tol", c->orb_tol);
  h |= h5_attr_long(g, "family", c->orb_family);
  h |= h5_attr_string(g, "family_name", c->orb_family == -1 ? "halo_north" : c->orb_family == -2 ? "halo_south"
                                         : c->orb_family == -3 ? "vertical"
                                         : guessed ? famname : "lyapunov");
  if (guessed) {
    h |= h5_attr_string(g, "family_end_reason", end_reason_text(reason));
    if (reason && reason != 5 && reason != 8) h |= h5_attr_double(g, "family_end_dE", end_de);
    if (c->orb_nguess > 0) {
      hsize_t dg = (hsize_t)c->orb_nguess;
      h |= h5_write_double(g, "guess", 1, &dg, c->orb_guess, "state units");
      h |= h5_attr_double(g, "guess_period", c->orb_period);
    }
  }
  if (dissipative(run)) h |= h5_attr_string(g, "model", "conservative");
  if (end_de > 0 && !guessed) {
    h |= h5_attr_double(g, "family_end_dE", end_de);
    h |= h5_attr_string(g, "family_end_reason", end_reason_text(reason));
  }
  {
    hsize_t dnp[2] = {(hsize_t)n, (hsize_t)np}, dbp[2] = {(hsize_t)nbif, (hsize_t)np}, db = (hsize_t)nbif;
    double *re = malloc(sizeof(double) * (size_t)np * (n > nbif ? n : nbif) + 1),
           *im = malloc(sizeof(double) * (size_t)np * (n > nbif ? n : nbif) + 1);
    int *kd = malloc(sizeof(int) * (size_t)nbif + 1), *af = malloc(sizeof(int) * (size_t)nbif + 1);
    if (!re || !im || !kd || !af) h = 1;
    else {
      for (int k = 0; k < n; k++)
        for (int i = 0; i < np; i++) { re[np * k + i] = nu[4 * k + i]; im[np * k + i] = nu[4 * k + 2 + i]; }
      h |= h5_write_double(g, "floquet_index", 2, dnp, re, NULL);
      h |= h5_write_double(g, "floquet_index_imag", 2, dnp, im, NULL);
      hid_t bg = h5_group(g, "bifurcations");
      if (bg < 0) h = 1;
      else {
        for (int j = 0; j < nbif; j++) {
          kd[j] = bkind[j]; af[j] = bafter[j];
          for (int i = 0; i < np; i++) { re[np * j + i] = bnu[4 * j + i]; im[np * j + i] = bnu[4 * j + 2 + i]; }
        }
        h |= h5_write_int(bg, "kind", db, kd, NULL);
        h |= h5_write_int(bg, "after", db, af, NULL);
        h |= h5_write_int(bg, "converged", db, bconv, NULL);
        h |= h5_write_double(bg, "dE", 1, &db, bde, NULL);
        h |= h5_write_double(bg, "bracket", 1, &db, bwid, NULL);
        h |= h5_write_double(bg, "energy", 1, &db, ben, NULL);
        h |= h5_write_double(bg, "period", 1, &db, bper, NULL);
        h |= h5_write_double(bg, "floquet_index", 2, dbp, re, NULL);
        h |= h5_write_double(bg, "floquet_index_imag", 2, dbp, im, NULL);
        hsize_t dbs[2] = {(hsize_t)nbif, (hsize_t)n2};
        for (int j = 0; j < nbif; j++)
          for (int i = 0; i < n2; i++) { bx0[n2 * j + i] = bx0[6 * j + i]; btan[n2 * j + i] = btan[6 * j + i]; }
        h |= h5_write_double(bg, "state0", 2, dbs, bx0, n2 == 4 ? "cm, cm, cm/s, cm/s" : "state units");
        h |= h5_write_double(bg, "tangent", 2, dbs, btan, NULL);
        h |= h5_attr_string(bg, "kinds", guessed ? "1 branch_point (an index crosses +1), 2 period_doubling (-1), "
                            "3 krein_collision (a pair of indices turns complex or real), 4 fold (the energy along "
                            "a guess's family turns back)" : "1 branch_point (an index crosses +1), 2 period_doubling "
                            "(-1), 3 krein_collision (a pair of indices turns complex or real)");
        h |= h5_attr_double(bg, "tol", btol);
        H5Gclose(bg);
      }
    }
    free(re); free(im); free(kd); free(af);
  }
  for (int k = 0; k < n && !h; k++) {
    char name[32];
    snprintf(name, sizeof name, "orbit_%03d", k);
    hid_t o = h5_group(g, name);
    if (o < 0) { h = 1; break; }
    hsize_t dsn = (hsize_t)ns, dx[2] = {(hsize_t)ns, (hsize_t)n2}, dh = (hsize_t)(it[k] < mi ? it[k] : mi);
    h |= h5_attr_double(o, "dE", c->orb_de[k]);
    h |= h5_attr_long(o, "converged", conv[k]);
    if (dh > 0) h |= h5_write_double(o, "history", 1, &dh, hist + (size_t)k * mi, NULL);
    if (conv[k]) {
      h |= h5_write_double(o, "t", 1, &dsn, ts + (size_t)k * ns, NULL);
      h |= h5_write_double(o, "state", 2, dx, xs + (size_t)n2 * k * ns, n2 == 4 ? "cm, cm, cm/s, cm/s" : "state units");
    }
    H5Gclose(o);
  }
  free(mre); free(mim); free(monot); free(nu);
  H5Gclose(g);
  if (h) rc = EXIT_IO;
  else if (nfail && !rc) rc = EXIT_PARTIAL;
out:
  free(cp); free(jac);
  free(e); free(per); free(act); free(s0); free(mu); free(ms); free(mt); free(stab); free(res); free(clo);
  free(md); free(mono); free(ts); free(xs); free(hist); free(it); free(conv);
  return rc;
}

/* ---------------------------------------------------------------- tube dynamics scenes */

/* ", N escaped" for the Monte Carlo line (a static buffer: one line at a time). */
static const char *escaped_text(int n) {
  static char b[48];
  snprintf(b, sizeof b, ", %d escaped (through another exit)", n);
  return b;
}

/* E_e, T_po of the saddle named by &orbits saddle. */
static int saddle_props(tubes_run_t *run, double *ee, double *tpo) {
  static eqlist_t L;
  int st = find_eqs(run, &L);
  if (st < 0) return st;
  int k = find_named(&L, run->saddle);
  if (k < 0 || L.rank1[k] != 1) return TUBES_EINPUT;
  *ee = L.en[k];
  *tpo = 2 * M_PI / L.om[(MD - 1) * k];
  return 0;
}

/* The section's arguments of the C API: kind, index, level, direction (include/tubes.h). */
#define SECTION(c) (sec_is_ray(c) ? 1 : 2), (c)->sec_index, (sec_is_ray(c) ? sec_angle(c) : (c)->sec_value), \
                   (sec_is_ray(c) ? (c)->sec_pth_sign : (c)->sec_direction)
static int orb_nseg(const tubes_config_t *c) { return strcmp(c->orb_method, "multiple") ? 1 : c->orb_n_segments; }

/* /section: the energy surface on the section at E_e (A0, tau, r range) and the growth rate. */
static int write_section(tubes_run_t *run, double *a0_out, double *tau_out, double *tpo_out) {
  const tubes_config_t *c = run->cfg;
  double ee, tpo, rmin, rmax, a0, tau;
  if (run->ndof > 2) {   /* the tubes scene's plane, for its crossings alone: no region, no A0 */
    int s3 = saddle_props(run, &ee, &tpo);
    if (s3 < 0) {
      fprintf(stderr, "tubes: section: the saddle %s could not be found (status %d)\n", run->saddle, s3);
      return EXIT_NUMERIC;
    }
    *a0_out = *tau_out = NAN;
    *tpo_out = tpo;
    if (H5Lexists(run->file, "section", H5P_DEFAULT) > 0) return 0;
    printf("section q%d = %.10g (dq%d/dt %s 0), %d degrees of freedom: the tubes' crossings of the plane (no "
           "region: the transition scenes are 2-DOF)\n", c->sec_index, c->sec_value, c->sec_index,
           c->sec_direction > 0 ? ">" : "<", run->ndof);
    hid_t g = h5_group(run->file, "section");
    if (g < 0) return EXIT_IO;
    int e = h5_attr_string(g, "kind", "plane");
    e |= h5_attr_long(g, "index", c->sec_index);
    e |= h5_attr_double(g, "value", c->sec_value);
    e |= h5_attr_long(g, "direction", c->sec_direction);
    e |= h5_attr_double(g, "E_e", ee);
    e |= h5_attr_string(g, "saddle", run->saddle);
    H5Gclose(g);
    return e ? EXIT_IO : 0;
  }
  int st = saddle_props(run, &ee, &tpo);
  if (!st) st = tubes_section_info(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, SECTION(c), 0.0, &rmin, &rmax, &a0, &tau, run->seeds);
  if (st < 0) {
    if (sec_is_ray(c) || st != TUBES_ENOREGION) {
      char m[TUBES_LSTATUS];
      status_text(st, m, sizeof m);
      fprintf(stderr, "tubes: section: the energy surface on the section could not be computed: %s (status %d)\n",
              m, st);
    } else
      fprintf(stderr, "tubes: section: the plane q%d = %g does not meet a bounded region of the energy surface at "
              "E_e of %s (searched q%d over the &equilibria box widened by half its width on each side; status %d): "
              "choose another value, or a box that holds the region\n", c->sec_index, c->sec_value, run->saddle,
              3 - c->sec_index, st);
    return EXIT_NUMERIC;
  }
  if (!isfinite(tau)) {            /* dA_E/dE's quadrature failed (the area stands): no tau to print */
    fprintf(stderr, "tubes: section: dA_E/dE at E_e of %s could not be computed (its quadrature did not "
            "converge; the energy surface on the section touches a maximum of V?)\n", run->saddle);
    return EXIT_NUMERIC;
  }
  *a0_out = a0; *tau_out = tau; *tpo_out = tpo;
  if (H5Lexists(run->file, "section", H5P_DEFAULT) > 0) return 0;
  if (sec_is_ray(c))
    printf("section theta = %g deg (p_theta %s 0): at E_e r in [%.6f, %.6f] cm, A0 = %.8g cm^2/s, "
           "tau = dA_E/dE = %.8g s, T_po/A0 = %.6g (s/cm)^2\n", c->sec_angle, c->sec_pth_sign > 0 ? ">" : "<",
           rmin, rmax, a0, tau, tpo / a0);
  else
    printf("section q%d = %.10g (dq%d/dt %s 0): at E_e q%d in [%.8g, %.8g], A0 = %.10g, tau = dA_E/dE = %.10g, "
           "T_po/A0 = %.6g\n", c->sec_index, c->sec_value, c->sec_index, c->sec_direction > 0 ? ">" : "<",
           3 - c->sec_index, rmin, rmax, a0, tau, tpo / a0);
  hid_t g = h5_group(run->file, "section");
  if (g < 0) return EXIT_IO;
  int e = 0;
  if (sec_is_ray(c)) {
    e |= h5_attr_double(g, "angle", sec_angle(c));
    e |= h5_attr_long(g, "p_theta_sign", c->sec_pth_sign);
  } else {
    e |= h5_attr_string(g, "kind", "plane");
    e |= h5_attr_long(g, "index", c->sec_index);
    e |= h5_attr_double(g, "value", c->sec_value);
    e |= h5_attr_long(g, "direction", c->sec_direction);
  }
  e |= h5_attr_double(g, "A0", a0);
  e |= h5_attr_double(g, "tau", tau);
  e |= h5_attr_double(g, "growth_rate", tpo / a0);
  e |= h5_attr_double(g, "T_po", tpo);
  e |= h5_attr_double(g, "E_e", ee);
  e |= h5_attr_string(g, "saddle", run->saddle);
  e |= h5_attr_double(g, "r_min", rmin);
  e |= h5_attr_double(g, "r_max", rmax);
  H5Gclose(g);
  return e ? EXIT_IO : 0;
}

/* The end of the saddle's orbit family, for a cut asked past it: where it ends and why, as the
 * orbits scene says (the run's stores hold the continuation the cut made). local = 1: the cut
 * was this rank's alone (without it, multiple shooting on one rank waited for the others). */
static void past_end_message(tubes_run_t *run, double de, char *buf, size_t len, int local) {
  const tubes_config_t *c = run->cfg;
  int mi = c->orb_max_iter, ns = c->orb_n_samples, conv = 0, it = 0, reason = 0;
  double e, per, act, s0[2 * MD], mu, ms, mt[4], stab, res, clo, md, mono[4 * MD * MD], end_de = -1,
      *hist = calloc(mi > 0 ? mi : 1, sizeof(double)), *ts = calloc(ns, sizeof(double)),
      *xs = calloc((size_t)2 * MD * ns, sizeof(double));
  if (hist && ts && xs)
    tubes_orbit_family(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, 1, &de, orb_nseg(c),
                       c->orb_family,
                       c->orb_tol, c->orb_rtol, c->orb_atol, mi, ns, INTEGRATOR(c), &e, &per, &act, s0, &mu, &ms, mt,
                       &stab, &res, &clo, &it, &conv, &md, mono, ts, xs, hist, &end_de, &reason, local, run->seeds, 0,
                       NULL, 0.0);
  free(hist); free(ts); free(xs);
  char m[448];
  family_stop_text(run, de, end_de, reason, m, sizeof m);
  snprintf(buf, len, "tubes: %s (and no tube)", m);
}

/* One tube cut into group loc (none if loc < 0); returns 0 or an exit code; *area gets the area.
 * local = 1: computed on this rank alone (the caller deals out cuts), else by all ranks together.
 * A failure is described in err (printed to stderr if err is NULL). */
static int cut_to(tubes_run_t *run, hid_t loc, const char *name, double de, int kind, double eps,
                  double area_tol, double *area, double *action, double *t_po_cut, int local, char *err,
                  size_t errlen, int *status) {
  const tubes_config_t *c = run->cfg;
  int nout = c->tub_n_max, n = 0, nh = 0, hn[64], nfail = 0;
  double *tau = malloc(sizeof(double) * nout), *r = malloc(sizeof(double) * nout), *pr = malloc(sizeof(double) * nout),
         *tm = malloc(sizeof(double) * nout), *xs = malloc(sizeof(double) * 2 * MD * nout), ha[64], ar = 0, ap = 0, act = 0, per = 0,
         ftau = 0, floq[2 * MD], sigma = 0;
  int rc = 0;
  if (!tau || !r || !pr || !tm || !xs) rc = EXIT_NUMERIC;
  int st = rc ? -1 : tubes_tube_cut(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, kind, SECTION(c), eps, area_tol,
                                    c->tub_t_max, c->tub_n_init, nout, orb_nseg(c), c->orb_family, c->orb_tol, c->orb_rtol, c->orb_atol,
                                    INTEGRATOR(c), nout, &n, tau, r, pr, tm, xs, &ar, &ap, &act, &per, &nh, hn, ha, &nfail, &ftau,
                                    floq, &sigma, local, run->seeds);
  if (err && errlen) err[0] = 0;
  if (status) *status = rc ? TUBES_EINPUT : st;
  if (st == TUBES_EPASTEND) {
    char buf[512];
    past_end_message(run, de, buf, sizeof buf, local);
    if (err) snprintf(err, errlen, "%s", buf);
    else fprintf(stderr, "%s\n", buf);
    rc = EXIT_PARTIAL;
  } else if (st < 0 && !rc) {
    char m[TUBES_LSTATUS], buf[2048];
    size_t len = 0;
    status_text(st, m, sizeof m);
    len += snprintf(buf + len, sizeof buf - len, "tubes: the cut at dE = %g failed: %s (status %d)", de, m, st);
    if (st == TUBES_ENOCONV && isnan(per) && len < sizeof buf)   /* the orbit, not the cut, failed */
      len += snprintf(buf + len, sizeof buf - len, ": no orbit of the %s family at this dE%s",
                      c->orb_family == -1 ? "halo_north" : c->orb_family == -2 ? "halo_south" : "saddle's",
                      c->orb_family < 0 ? " (below the branch point of the planar family, where the halo branch "
                                          "starts: the orbits scene locates it, /orbits/bifurcations; or beyond the "
                                          "branch's continuation)" : "");
    if (st == TUBES_EINPUT && run->ndof > 2 && len < sizeof buf)
      len += snprintf(buf + len, sizeof buf - len, ": the plane q%d = %g passes through the saddle %s (no side for "
                      "the manifold's branch to go to), or the orbit has no hyperbolic multiplier (no stable and "
                      "unstable manifolds)", c->sec_index, c->sec_value, run->saddle);
    if (st == TUBES_ENOCROSS && !sec_is_ray(c) && len < sizeof buf)
      len += snprintf(buf + len, sizeof buf - len, ": the %s manifold's branch towards the plane q%d = %g does not "
                      "reach it (crossing it with dq%d/dt %s 0) within &tubes t_max = %g; raise t_max or choose "
                      "another plane or direction", kind < 0 ? "stable" : "unstable", c->sec_index, c->sec_value,
                      c->sec_index, c->sec_direction > 0 ? ">" : "<", c->tub_t_max);
    if (nfail > 0 && len < sizeof buf)
      len += snprintf(buf + len, sizeof buf - len, "; %d seed(s) failed, the first at orbit phase tau = %.10g s of "
                      "T = %.10g s", nfail, ftau, per);
    if (nh > 0 && len < sizeof buf) {
      len += snprintf(buf + len, sizeof buf - len, "; area after each round:");
      for (int k = 0; k < nh && len < sizeof buf; k++) len += snprintf(buf + len, sizeof buf - len, " %d:%.12g", hn[k], ha[k]);
    }
    if (err) snprintf(err, errlen, "%s", buf);
    else fprintf(stderr, "%s\n", buf);
    rc = EXIT_PARTIAL;
  }
  if (loc >= 0 && n > 0) {
    hid_t g = h5_group(loc, name);
    int nd = run->ndof;
    hsize_t dn = (hsize_t)n, d4[2] = {(hsize_t)n, (hsize_t)(2 * nd)}, dh = (hsize_t)nh;
    int e = g < 0;
    e |= h5_write_double(g, "r", 1, &dn, r, NULL);
    e |= h5_write_double(g, "p_r", 1, &dn, pr, NULL);
    e |= h5_write_double(g, "time", 1, &dn, tm, NULL);
    e |= h5_write_double(g, "tau", 1, &dn, tau, NULL);
    e |= h5_write_double(g, "state", 2, d4, xs, nd == 2 ? "cm, cm, cm/s, cm/s" : NULL);
    if (nd > 2) {   /* the plane's pairs (q_j, p_j), j != index: the cut is a closed curve in them */
      double *sc = malloc(sizeof(double) * (size_t)n * 2 * (nd - 1));
      hsize_t ds[2] = {(hsize_t)n, (hsize_t)(2 * (nd - 1))};
      char axes[64] = "";
      for (int j = 1, l = 0; j <= nd; j++) {
        if (j == c->sec_index) continue;
        for (int i = 0; sc && i < n; i++) {
          sc[(size_t)i * 2 * (nd - 1) + l] = xs[(size_t)i * 2 * nd + j - 1];
          sc[(size_t)i * 2 * (nd - 1) + l + 1] = xs[(size_t)i * 2 * nd + nd + j - 1];
        }
        l += 2;
        size_t al = strlen(axes);
        snprintf(axes + al, sizeof axes - al, "%sq%d p%d", al ? " " : "", j, j);
      }
      e |= !sc;
      if (sc) e |= h5_write_double(g, "section", 2, ds, sc, NULL);
      free(sc);
      e |= h5_attr_string(g, "axes", axes);
      e |= h5_attr_long(g, "section_index", c->sec_index);
      e |= h5_attr_double(g, "section_value", c->sec_value);
      e |= h5_attr_long(g, "section_direction", c->sec_direction);
    }
    if (nh > 0) {
      e |= h5_write_int(g, "history_n", dh, hn, NULL);
      e |= h5_write_double(g, "history_area", 1, &dh, ha, NULL);
    }
    e |= h5_attr_double(g, "dE", de);
    e |= h5_attr_string(g, "kind", kind < 0 ? "stable" : "unstable");
    e |= h5_attr_double(g, "area", ar);
    e |= h5_attr_double(g, "area_polygon", ap);
    e |= h5_attr_double(g, "action", act);
    e |= h5_attr_double(g, "period", per);
    e |= h5_attr_double(g, "eps", eps);
    e |= h5_attr_long(g, "converged", st >= 0);
    if (nd > 2) {   /* (2 DOF: the Lyapunov family alone, the paper's cuts as they were) */
      hsize_t d2n = (hsize_t)(2 * nd);
      e |= h5_attr_long(g, "family", c->orb_family);
      e |= h5_write_double(g, "floquet_vector", 1, &d2n, floq, NULL);
      e |= h5_attr_double(g, "sigma", sigma);
    }
    if (g >= 0) H5Gclose(g);
    if (e) rc = EXIT_IO;
  }
  *area = st < 0 ? NAN : ar;
  *action = act;
  *t_po_cut = per;
  free(tau); free(r); free(pr); free(tm); free(xs);
  return rc;
}

/* The start of a scene that draws on the section (tubes, sections): /section (write_section), then
 * the scene's own group in *g. */
static int section_scene(tubes_run_t *run, const char *name, hid_t *g) {
  double a0, tau, tpo;
  int rc = write_section(run, &a0, &tau, &tpo);
  if (rc) return rc;
  *g = h5_group(run->file, name);
  return *g < 0 ? EXIT_IO : 0;
}

/* A transition region of the run's model with its dissipation (tubes_transition_region): the
 * Monte Carlo's transit test (&montecarlo gate, t_max), area_tol relative. */
enum { REGION_NOUT = 4096, REGION_CURVE = 4096 };
typedef struct {
  int st, n, m, counts[8];
  double res[12], phi[REGION_NOUT], rho[REGION_NOUT], s[REGION_NOUT], p[REGION_NOUT], t_in[REGION_NOUT],
      cs[REGION_CURVE], cp[REGION_CURVE];
} region_out_t;

static int region_run(const tubes_run_t *run, double de, double area_tol, int local, region_out_t *o,
                      int noiseless) {
  const tubes_config_t *c = run->cfg;
  o->st = tubes_transition_region(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, SECTION(c),
                                  c->mc_gate, c->mc_t_max, area_tol, INTEGRATOR(c), REGION_NOUT, REGION_CURVE, &o->n,
                                  o->phi, o->rho, o->s, o->p, o->t_in, &o->m, o->cs, o->cp, o->res, o->counts, local,
                                  noiseless, run->seeds);
  return o->st;
}

/* The region's failure (or its empty threshold) in words, into buf. */
static void region_text(const tubes_run_t *run, double de, const region_out_t *o, char *buf, size_t len) {
  char m[TUBES_LSTATUS];
  buf[0] = 0;
  if (o->st == TUBES_ENARROW) {
    snprintf(buf, len, "tubes: the transition region at dE = %g: &montecarlo gate = %g%s lies within twice the "
             "reach of the NHIM across saddle %s's neck (raise gate; docs/input.md)", de, run->cfg->mc_gate,
             in_units(" cm"), run->saddle);
  } else if (o->st < 0 && o->counts[0] == 0) {
    status_text(o->st, m, sizeof m);
    snprintf(buf, len, "tubes: the transition region at dE = %g failed: %s (status %d)", de, m, o->st);
  } else if (o->st < 0) {
    status_text(o->st, m, sizeof m);
    snprintf(buf, len, "tubes: the transition region at dE = %g failed: %s (status %d); %d scan points, %d transit, "
             "%d undecided, %d on the wrong side of the traced boundary", de, m, o->st, o->counts[0], o->counts[1],
             o->counts[2], o->counts[3]);
  }
}

/* The damped model's transition regions at &tubes de, into /tubes/region_<k> (docs/output.md). */
static int tubes_regions(tubes_run_t *run, hid_t g) {
  const tubes_config_t *c = run->cfg;
  region_out_t *reg = malloc(sizeof *reg);
  if (!reg) return EXIT_NUMERIC;
  int rc = 0;
  printf("tubes: the dissipative model (%s): its transition regions, the section points that pass the "
         "saddle's gate (the cut of the damped saddle's stable manifold; area_tol %g)\n", run->dissip, c->tub_area_tol);
  printf("  %10s %16s %12s %6s %10s %8s\n", "dE", "area", "p_trans", "rays", "scan", "s");
  for (int k = 0; k < c->tub_nde; k++) {
    double de = c->tub_de[k], t0 = now();
    progress_item("tubes: the damped region at dE = %g (%d of %d)...\n", de, k + 1, c->tub_nde);
    int st = region_run(run, de, c->tub_area_tol, 0, reg, 0);
    if (st < 0) {
      char m[1024];
      region_text(run, de, reg, m, sizeof m);
      fprintf(stderr, "%s\n", m);
      printf("  %10.4g   failed (status %d)\n", de, st);
      rc = EXIT_PARTIAL;
      continue;
    }
    int empty = reg->counts[6];
    double area = empty ? 0 : reg->res[0], ae = reg->res[7];
    if (empty)
      printf("  %10.4g %16.12g %12.6g %6s %4d/%-5d %8.2f   no point transits (none at dE <= %.8g)\n", de, 0.0, 0.0, "-",
             reg->counts[1], reg->counts[0], now() - t0, reg->res[8]);
    else
      printf("  %10.4g %16.12g %12.6g %6d %4d/%-5d %8.2f\n", de, area, area / ae, reg->n, reg->counts[1],
             reg->counts[0], now() - t0);
    char name[32];
    snprintf(name, sizeof name, "region_%03d", k);
    hid_t o = h5_group(g, name);
    hsize_t dn = (hsize_t)reg->n, dm = (hsize_t)reg->m;
    int e = o < 0;
    if (reg->n > 0) {
      e |= h5_write_double(o, "r", 1, &dn, reg->s, NULL);
      e |= h5_write_double(o, "p_r", 1, &dn, reg->p, NULL);
      e |= h5_write_double(o, "phi", 1, &dn, reg->phi, NULL);
      e |= h5_write_double(o, "rho", 1, &dn, reg->rho, NULL);
      e |= h5_write_double(o, "t_in", 1, &dn, reg->t_in, NULL);
      e |= h5_write_double(o, "curve_r", 1, &dm, reg->cs, NULL);
      e |= h5_write_double(o, "curve_p_r", 1, &dm, reg->cp, NULL);
    }
    e |= h5_attr_double(o, "dE", de);
    e |= h5_attr_double(o, "area", area);
    e |= h5_attr_double(o, "area_polygon", reg->res[1]);
    e |= h5_attr_double(o, "A_E", ae);
    e |= h5_attr_double(o, "p_trans", area / ae);
    e |= h5_attr_long(o, "empty", empty);
    e |= h5_attr_double(o, "dE_threshold_lo", reg->res[8]);
    e |= h5_attr_double(o, "dE_threshold_hi", reg->res[9]);
    double cen[2] = {reg->res[2], reg->res[3]}, sc[2] = {reg->res[4], reg->res[5]};
    hsize_t d2 = 2;
    e |= h5_write_double(o, "centre", 1, &d2, cen, NULL);
    e |= h5_write_double(o, "scale", 1, &d2, sc, NULL);
    e |= h5_attr_long(o, "n_scan", reg->counts[0]);
    e |= h5_attr_long(o, "n_scan_transit", reg->counts[1]);
    e |= h5_attr_long(o, "n_inconsistent", reg->counts[3]);
    e |= dissipation_attrs(o, run);
    if (o >= 0) H5Gclose(o);
    if (e) { rc = EXIT_IO; break; }
  }
  free(reg);
  return rc;
}

int scene_tubes(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  hid_t g;
  int rc = section_scene(run, "tubes", &g);
  if (rc) return rc;
  printf("tubes: %s manifold cuts on the section (eps = %g %s, area_tol = %g)%s\n", c->tub_kind, c->tub_eps,
         strcmp(run->length_units, "1") ? run->length_units : "(length units)", c->tub_area_tol,
         dissipative(run) ? ": the conservative model's Lyapunov orbits and tubes (a damped model has neither)" : "");
  printf("  %10s %8s %16s %16s %11s %11s %8s\n", "dE", "kind", "area", "action", "area/action-1", "eps/10 chg", "s");
  for (int k = 0; k < c->tub_nde; k++) {
    for (int kind = -1; kind <= 1; kind += 2) {
      if (kind < 0 && !strcmp(c->tub_kind, "unstable")) continue;
      if (kind > 0 && !strcmp(c->tub_kind, "stable")) continue;
      char name[48];
      double a, a10, act, per, t0 = now(), de = c->tub_de[k];
      progress_item("tubes: dE = %g, %s manifold (%d of %d)...\n", de, kind < 0 ? "stable" : "unstable", k + 1,
                    c->tub_nde);
      snprintf(name, sizeof name, "%s_%03d", kind < 0 ? "stable" : "unstable", k);
      int st1 = 0;
      int r1 = cut_to(run, g, name, de, kind, c->tub_eps, c->tub_area_tol, &a, &act, &per, 0, NULL, 0, &st1);
      if (r1 == EXIT_IO) { H5Gclose(g); return EXIT_IO; }
      if (st1 == TUBES_EPASTEND) {
        printf("  %10.4g %8s   refused: past the end of the family (no orbit at this energy)\n", de,
               kind < 0 ? "stable" : "unstable");
        rc = EXIT_PARTIAL;
        continue;
      }
      /* the eps/10 repetition of a cut that failed would only fail again (and say so twice) */
      int r2 = r1 ? (a10 = NAN, 0)
                  : cut_to(run, -1, "", de, kind, c->tub_eps / 10, c->tub_area_tol, &a10, &act, &per, 0, NULL, 0, NULL);
      if (r1 || r2) rc = EXIT_PARTIAL;
      char path[80];
      snprintf(path, sizeof path, "%s", name);
      if (H5Lexists(g, path, H5P_DEFAULT) > 0) {
        hid_t o = H5Gopen2(g, path, H5P_DEFAULT);
        h5_attr_double(o, "area_eps10", a10);
        h5_attr_double(o, "area_eps_change", fabs(a - a10));
        H5Gclose(o);
      }
      printf("  %10.4g %8s %16.12g %16.12g %11.2e %11.2e %8.2f\n", de, kind < 0 ? "stable" : "unstable", a, act,
             a / act - 1, fabs(a - a10), now() - t0);
    }
  }
  if (dissipative(run)) {
    int r2 = tubes_regions(run, g);
    if (r2 == EXIT_IO) rc = EXIT_IO;
    else if (r2 && !rc) rc = r2;
  }
  H5Gclose(g);
  return rc;
}

/* Whole energies are dealt out to the MPI ranks (energy k on rank k mod nranks), each computed by
 * the rank alone with its OpenMP threads; the results and messages are then shared from each
 * energy's owner, and rank 0 prints them in energy order. */
typedef struct {
  double at, act, ae, pt, secs;
  int rc, status;
  char err[2048];
  /* a dissipative model: its region's area and fraction, threshold, status, rays */
  double ar, pd, de_lo, de_hi, area_hi;
  int rstatus, empty, nrays;
} transition_item_t;

static void share_from(void *buf, int bytes, int owner, const tubes_run_t *run) {
#ifdef TUBES_MPI
  if (run->nranks > 1) MPI_Bcast(buf, bytes, MPI_BYTE, owner, MPI_COMM_WORLD);
#else
  (void)buf; (void)bytes; (void)owner; (void)run;
#endif
}

int scene_transition(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  double a0, tau, tpo;
  int rc = write_section(run, &a0, &tau, &tpo);
  if (rc) return rc;
  int n = c->tra_nde, damped = dissipative(run);
  double *at = calloc(n, sizeof(double)), *act = calloc(n, sizeof(double)), *ae = calloc(n, sizeof(double)),
         *pt = calloc(n, sizeof(double)), *pl = calloc(n, sizeof(double)), *ar = calloc(n, sizeof(double)),
         *pd = calloc(n, sizeof(double));
  transition_item_t *it = calloc(n, sizeof(transition_item_t));
  int *stat = calloc(n, sizeof(int)), *rstat = calloc(n, sizeof(int)), *nrays = calloc(n, sizeof(int));
  region_out_t *reg = damped ? malloc(sizeof *reg) : NULL;
  if (!at || !act || !ae || !pt || !pl || !ar || !pd || !it || !stat || !rstat || !nrays || (damped && !reg)) {
    fprintf(stderr, "tubes: transition: out of memory\n");
    free(at); free(act); free(ae); free(pt); free(pl); free(ar); free(pd); free(it); free(stat); free(rstat);
    free(nrays); free(reg);
    return EXIT_NUMERIC;
  }
  if (run->nranks > 1)
    fprintf(stderr, "transition: %d energies dealt out to %d MPI ranks\n", n, run->nranks);
  for (int k = 0; k < n; k++) {
    if (k % run->nranks != run->rank) continue;
    transition_item_t *x = &it[k];
    double de = c->tra_de[k], rmin, rmax, darea, per, t0 = now();
    progress_item("transition: dE = %g (%d of %d)...\n", de, k + 1, n);
    int r1 = cut_to(run, -1, "", de, -1, c->tub_eps, c->tra_area_tol, &x->at, &x->act, &per, 1, x->err,
                    sizeof x->err, &x->status);
    int st = tubes_section_info(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, SECTION(c), de, &rmin, &rmax, &x->ae, &darea, run->seeds);
    if (st < 0) {
      char m[TUBES_LSTATUS];
      status_text(st, m, sizeof m);
      size_t l = strlen(x->err);
      snprintf(x->err + l, sizeof x->err - l, "%stubes: transition: the energy surface on the section at dE = %g: "
               "%s (status %d)", l ? "\n" : "", de, m, st);
    }
    x->rc = (r1 || st < 0) ? EXIT_PARTIAL : 0;
    if (x->status >= 0 && st < 0) x->status = st;
    if (st < 0) x->ae = NAN;          /* the failed call's area is no number of the program's */
    if (x->status < 0 && x->act == 0) x->act = NAN;   /* no orbit (past the family's end): no action */
    x->pt = (st < 0) ? NAN : x->at / x->ae;
    x->ar = x->pd = x->de_lo = x->de_hi = x->area_hi = NAN;
    if (damped) {            /* the dissipative model's region: p_trans is its fraction */
      int rs = region_run(run, de, c->tra_area_tol, 1, reg, 0);
      x->rstatus = rs;
      x->empty = reg->counts[6];
      x->nrays = reg->n;
      x->de_lo = reg->res[8]; x->de_hi = reg->res[9]; x->area_hi = reg->res[10];
      if (rs >= 0) {
        x->ar = x->empty ? 0 : reg->res[0];
        x->pd = st < 0 ? NAN : x->ar / x->ae;
      } else {
        char m[1024];
        size_t l = strlen(x->err);
        region_text(run, de, reg, m, sizeof m);
        snprintf(x->err + l, sizeof x->err - l, "%s%s", l ? "\n" : "", m);
        x->rc = EXIT_PARTIAL;
      }
    }
    x->secs = now() - t0;
  }
  for (int k = 0; k < n; k++) share_from(&it[k], (int)sizeof it[k], k % run->nranks, run);
  if (damped) {
    printf("transition: the dissipative model (%s): p_trans(dE) = A_region / A_E on %d energies, A_region the "
           "section points that pass the saddle's gate (area_tol %g); beside it the conservative model's A_tube / A_E\n",
           run->dissip, n, c->tra_area_tol);
    printf("  %10s %14s %14s %14s %12s %12s %6s\n", "dE", "A_region", "A_tube", "A_E", "p_trans", "conservative",
           "rays");
  } else {
    printf("transition: p_trans(dE) = A_tube / A_E on %d energies (area_tol %g)\n", n, c->tra_area_tol);
    printf("  %10s %14s %14s %14s %12s %12s\n", "dE", "A_tube", "action", "A_E", "p_trans", "leading");
  }
  int beyond = 0;   /* energies where the leading order's correction tau dE / A0 exceeds LEADING_RANGE */
  double th_lo = NAN, th_hi = NAN, th_area = NAN;   /* the damped region's threshold, where one was found */
  for (int k = 0; k < n; k++) {
    double de = c->tra_de[k];
    at[k] = it[k].at; act[k] = it[k].act; ae[k] = it[k].ae; pt[k] = it[k].pt;
    ar[k] = it[k].ar; pd[k] = it[k].pd; rstat[k] = it[k].rstatus; nrays[k] = it[k].nrays;
    pl[k] = tubes_p_trans_leading(tpo, a0, tau, de);
    if (it[k].err[0]) fprintf(stderr, "%s\n", it[k].err);
    if (it[k].rc) rc = EXIT_PARTIAL;
    stat[k] = it[k].status;
    if (damped) {
      if (it[k].empty && !isnan(it[k].de_lo) && (isnan(th_lo) || it[k].de_lo > th_lo)) {
        th_lo = it[k].de_lo; th_hi = it[k].de_hi; th_area = it[k].area_hi;
      }
      char cons[16];
      if (it[k].status == TUBES_EPASTEND) snprintf(cons, sizeof cons, "%12s", "past end");
      else snprintf(cons, sizeof cons, "%12.6g", pt[k]);
      if (rstat[k] < 0)
        printf("  %10.4g   failed (status %d, stderr says why)%25s %s  (%.1f s)\n", de, rstat[k], "", cons, it[k].secs);
      else if (it[k].empty)
        printf("  %10.4g %14.8g %14.8g %14.8g %12.6g %s %6s  (%.1f s)\n", de, 0.0, at[k], ae[k], pd[k], cons, "-",
               it[k].secs);
      else
        printf("  %10.4g %14.8g %14.8g %14.8g %12.6g %s %6d  (%.1f s)\n", de, ar[k], at[k], ae[k], pd[k], cons,
               nrays[k], it[k].secs);
    } else if (it[k].status == TUBES_EPASTEND)
      printf("  %10.4g   refused: past the end of the family (no orbit at this energy)\n", de);
    else {
      int out = fabs(tau / a0 * de) > LEADING_RANGE;
      beyond += out;
      printf("  %10.4g %14.8g %14.8g %14.8g %12.6g %12.6g%s  (%.1f s)\n", de, at[k], act[k], ae[k], pt[k], pl[k],
             out ? "*" : " ", it[k].secs);
    }
  }
  if (damped && !isnan(th_lo)) {
    if (isnan(th_hi))
      printf("  no point of the section found to transit at dE <= %g (the scan and the search up to there)\n",
             th_lo);
    else if (th_area > 0)
      printf("  the region closes between dE = %.8g and %.8g (area %.3g at the upper end): the search from its "
             "centre finds no point that transits at dE <= %.8g\n", th_lo, th_hi, th_area, th_lo);
    else   /* the upper end's region: a point that transits, too small or ragged to trace */
      printf("  the region closes between dE = %.8g and %.8g (at the upper end a point transits, its region "
             "too small to trace): the search from its centre finds no point that transits at dE <= %.8g\n",
             th_lo, th_hi, th_lo);
  }
  if (beyond)
    printf("  * the leading order (T_po/A0) dE (1 - tau dE/A0) is outside its range there: tau dE/A0 > %g "
           "(p_trans is A_tube/A_E, computed)\n", LEADING_RANGE);
  hid_t g = h5_group(run->file, "transition");
  int e = g < 0;
  hsize_t dn = (hsize_t)n;
  e |= h5_write_double(g, "dE", 1, &dn, c->tra_de, NULL);
  e |= h5_write_double(g, "A_tube", 1, &dn, at, NULL);
  e |= h5_write_double(g, "action", 1, &dn, act, NULL);
  e |= h5_write_double(g, "A_E", 1, &dn, ae, NULL);
  e |= h5_write_double(g, "p_trans", 1, &dn, damped ? pd : pt, NULL);
  e |= h5_write_double(g, "p_trans_leading", 1, &dn, pl, NULL);
  e |= h5_write_int(g, "status", dn, damped ? rstat : stat, NULL);
  if (damped) {
    e |= h5_write_double(g, "A_region", 1, &dn, ar, NULL);
    e |= h5_write_double(g, "p_trans_conservative", 1, &dn, pt, NULL);
    e |= h5_write_int(g, "status_conservative", dn, stat, NULL);
    e |= h5_write_int(g, "region_rays", dn, nrays, NULL);
    e |= dissipation_attrs(g, run);
    e |= h5_attr_double(g, "dE_threshold_lo", th_lo);
    e |= h5_attr_double(g, "dE_threshold_hi", th_hi);
  }
  if (g >= 0) H5Gclose(g);
  free(at); free(act); free(ae); free(pt); free(pl); free(ar); free(pd); free(it); free(stat); free(rstat);
  free(nrays); free(reg);
  return e ? EXIT_IO : rc;
}

/* The /montecarlo group with what every outcome records: dE, n_samples, seed, status, and the
 * points (r, p_r, transit) when they were integrated (r != NULL). *e collects write errors. */
static hid_t mc_group(tubes_run_t *run, double de, int ns, int st, const double *r, const double *pr,
                      const int *out, int *e) {
  hid_t g = h5_group(run->file, "montecarlo");
  hsize_t dn = (hsize_t)ns;
  *e |= g < 0;
  *e |= h5_attr_double(g, "dE", de);
  *e |= h5_attr_long(g, "n_samples", ns);
  *e |= h5_attr_long(g, "seed", run->cfg->mc_seed);
  *e |= h5_attr_long(g, "status", st);
  if (r) {
    *e |= h5_write_double(g, "r", 1, &dn, r, NULL);
    *e |= h5_write_double(g, "p_r", 1, &dn, pr, NULL);
    *e |= h5_write_int(g, "transit", dn, out, NULL);
  }
  return g;
}

int scene_montecarlo(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  double a0, tau, tpo;
  int rc = write_section(run, &a0, &tau, &tpo);
  if (rc) return rc;
  int nout = c->tub_n_max, n = 0, nh = 0, hn[64], nfail = 0;
  double ftau = 0, floq[2 * MD], sigma = 0, de = c->mc_de, *tau_ = malloc(sizeof(double) * nout), *cr = malloc(sizeof(double) * nout),
         *cp = malloc(sizeof(double) * nout), *tm = malloc(sizeof(double) * nout), *xs = malloc(sizeof(double) * 2 * MD * nout),
         ha[64], ar = 0, ap = 0, act = 0, per = 0, rmin, rmax, ae, darea, t0 = now();
  int ns = c->mc_n_samples, damped = dissipative(run);
  double *r = malloc(sizeof(double) * ns), *pr = malloc(sizeof(double) * ns), p_cons = NAN;
  int *out = malloc(sizeof(int) * ns), *ins = malloc(sizeof(int) * ns);
  region_out_t *reg = damped ? malloc(sizeof *reg) : NULL;
  fprintf(stderr, "montecarlo: the tube cut at dE = %g...\n", de);
  int st = tubes_tube_cut(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, -1, SECTION(c), c->tub_eps, c->mc_area_tol,
                          c->tub_t_max, c->tub_n_init, nout, orb_nseg(c), c->orb_family, c->orb_tol, c->orb_rtol,
                          c->orb_atol, INTEGRATOR(c), nout,
                          &n, tau_, cr, cp, tm, xs, &ar, &ap, &act, &per, &nh, hn, ha, &nfail, &ftau, floq, &sigma, 0,
                          run->seeds);
  if (st < 0 && nfail > 0)
    fprintf(stderr, "tubes: montecarlo: the tube cut at dE = %g: %d seed(s) failed, the first at orbit phase "
            "tau = %.10g s\n", de, nfail, ftau);
  if (st >= 0) st = tubes_section_info(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, SECTION(c), de, &rmin, &rmax, &ae, &darea, run->seeds);
  if (st >= 0 && damped) {
    /* the dissipative model's prediction: its transition region (the conservative tube's fraction
     * beside it); the points are sorted by the region's boundary */
    p_cons = ar / ae;
    fprintf(stderr, "montecarlo: the damped model's transition region at dE = %g...\n", de);
    if (!reg) st = TUBES_EINPUT;
    else if (region_run(run, de, c->mc_area_tol, 0, reg, 1) < 0) {
      char m[1024];
      region_text(run, de, reg, m, sizeof m);
      fprintf(stderr, "%s\n", m);
      st = reg->st;
    } else {
      ar = reg->counts[6] ? 0 : reg->res[0];
      n = reg->counts[6] ? 0 : reg->m;
      for (int k = 0; k < n && k < nout; k++) { cr[k] = reg->cs[k]; cp[k] = reg->cp[k]; }
      if (n > nout) n = nout;
    }
  }
  int mc_ran = 0;
  if (st >= 0) {
    mc_ran = 1;
    fprintf(stderr, "montecarlo: integrating %d points...\n", ns);
    st = tubes_monte_carlo(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, SECTION(c), ns, c->mc_seed, c->mc_t_max,
                           c->mc_gate, INTEGRATOR(c), n, cr, cp, r, pr, out, ins, run->seeds);
  }
  if (st < 0) {
    char m[512];
    status_text(st, m, sizeof m);
    double reach = 0;
    if (st == TUBES_EPASTEND) {
      past_end_message(run, de, m, sizeof m, 0);
      fprintf(stderr, "%s\n", m);
    } else if (st == TUBES_ENARROW &&
               !tubes_gate_reach(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, &reach,
                                 run->seeds)) {
      /* refused before any sample was integrated */
      mc_ran = 0;
      say_at(run, nml_line(run->where, "montecarlo", "gate"));
      fprintf(stderr, "&montecarlo: gate = %g%s lies within twice the reach of the NHIM (the Lyapunov orbits) across "
              "saddle %s's neck at dE = %g (%.3g%s): orbits near it swing past the gate and back and would count as "
              "transits; allowed: gate > %.3g%s (docs/input.md)\n", c->mc_gate, in_units(" cm"), run->saddle, de, reach,
              in_units(" cm"), 2 * reach, in_units(" cm"));
    } else
      fprintf(stderr, "tubes: montecarlo: failed: %s (status %d)\n", m, st);
    int nbad = 0, first = -1;
    if (st == TUBES_EINTERRUPT) mc_ran = 0;   /* stopped: the samples not drawn did not fail */
    for (int k = 0; k < ns && mc_ran; k++)
      if (out[k] < 0) {
        if (first < 0) first = k;
        nbad++;
      }
    if (first >= 0) {
      status_text(out[first], m, sizeof m);
      fprintf(stderr, "tubes: montecarlo: %d of %d samples failed; the first, sample %d at (r, p_r) = (%.10g%s, "
              "%.10g%s): %s (status %d)\n", nbad, ns, first + 1, r[first], in_units(" cm"), pr[first],
              in_units(" cm/s"), m, out[first]);
    }
    rc = st == TUBES_EPASTEND ? EXIT_PARTIAL : EXIT_NUMERIC;
    /* the failure is recorded in the file (docs/output.md): the scene's status, no fraction */
    int e = 0;
    hid_t g = mc_group(run, de, ns, st, mc_ran ? r : NULL, pr, out, &e);
    status_text(st, m, sizeof m);
    e |= h5_attr_string(g, "status_message", m);
    e |= h5_attr_long(g, "agrees", 0);
    if (g >= 0) H5Gclose(g);
    if (e) rc = EXIT_IO;
  } else {
    int nt = 0, nu = 0, in_nt = 0, out_t = 0, nin = 0, nesc = 0, ntrap = 0;
    for (int k = 0; k < ns; k++) {
      nt += out[k] == 1;
      nu += out[k] == 2;
      nesc += out[k] == 3;   /* left for good through another exit: no transition */
      ntrap += out[k] == 4;  /* fell below the saddle's energy (dissipative): no transition */
      nin += ins[k];
      in_nt += ins[k] && out[k] != 1;
      out_t += !ins[k] && out[k] == 1;
    }
    /* the two answers must agree (tubes_verdicts mc_check, Python's monte_carlo's too): the direct
     * count within MC_SIGMA standard errors of the tube's p_trans, few misclassified, few
     * undecided; else the run says so and exits 2 (docs/tubes.md, "Monte Carlo check") */
    double f = (double)nt / ns, se = sqrt(f * (1 - f) / ns), p = ar / ae, nsig;
    int agrees;
    char verdict[1024];
    tubes_verdict_montecarlo(de, ns, nt, nu, in_nt + out_t, p, run->noisy, run->saddle, &nsig, &agrees, verdict,
                             (int)sizeof verdict);
    if (run->noisy) {   /* no deterministic prediction to hold it to: the fraction under noise, beside the
                         * noise-free region's (its D -> 0 limit); only the undecided count is checked */
      printf("montecarlo: the noisy model (%s), dE = %g, %d points: transition fraction %.5f +- %.5f under noise "
             "(the noise-free region's p_trans = %.5f, %+.1f standard errors from it; conservative A_tube/A_E = %.5f); "
             "%d points end otherwise than the noise-free region says; %d undecided%s (%.1f s)\n",
             run->dissip, de, ns, f, se, p, se > 0 ? (f - p) / se : 0.0, p_cons, in_nt + out_t, nu,
             nesc ? escaped_text(nesc) : "", now() - t0);
    } else if (damped)
      printf("montecarlo: the dissipative model (%s), dE = %g, %d points: transition fraction "
             "%.5f +- %.5f (p_trans = A_region/A_E = %.5f, %.1f standard errors; conservative A_tube/A_E = %.5f); %d "
             "inside the region; misclassified %d (inside, no transit) + %d (outside, transit); %d fell below E_e; %d "
             "undecided%s (%.1f s)\n",
             run->dissip, de, ns, f, se, p, nsig, p_cons, nin, in_nt, out_t, ntrap, nu,
             nesc ? escaped_text(nesc) : "", now() - t0);
    else
      printf("montecarlo: dE = %g, %d points: transition fraction %.5f +- %.5f (p_trans = %.5f, %.1f standard errors);"
             " %d inside the tube; misclassified %d (inside, no transit) + %d (outside, transit); %d undecided%s (%.1f s)\n",
             de, ns, f, se, p, nsig, nin, in_nt, out_t, nu, nesc ? escaped_text(nesc) : "", now() - t0);
    int e = 0;
    hsize_t dn = (hsize_t)ns;
    hid_t g = mc_group(run, de, ns, 0, r, pr, out, &e);
    if (damped) {
      e |= dissipation_attrs(g, run);
      e |= h5_attr_double(g, "p_trans_conservative", p_cons);
      e |= h5_attr_string(g, "predicted_by", run->noisy ? "none (noise): p_trans is the noise-free region's" : "region");
    }
    e |= h5_attr_double(g, "fraction", f);
    e |= h5_attr_double(g, "std_error", se);
    e |= h5_attr_double(g, "p_trans", p);
    e |= h5_attr_long(g, "misclassified", in_nt + out_t);
    e |= h5_attr_long(g, "misclassified_inside_no_transit", in_nt);
    e |= h5_attr_long(g, "misclassified_outside_transit", out_t);
    e |= h5_attr_long(g, "undecided", nu);
    e |= h5_attr_long(g, "escaped", nesc);
    if (damped) e |= h5_attr_long(g, "trapped", ntrap);
    e |= h5_write_int(g, "inside", dn, ins, NULL);
    e |= h5_attr_long(g, "agrees", agrees);
    if (g >= 0) H5Gclose(g);
    if (e) rc = EXIT_IO;
    else if (!agrees) {
      fprintf(stderr, "%s\n", verdict);
      rc = EXIT_NUMERIC;
    }
  }
  free(tau_); free(cr); free(cp); free(tm); free(xs); free(r); free(pr); free(out); free(ins); free(reg);
  return rc;
}

int scene_sections(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  hid_t g;
  int rc = section_scene(run, "sections", &g);
  if (rc) return rc;
  H5Gclose(g);
  for (int k = 0; k < c->pm_nde; k++) {   /* a map's record written before the next starts */
    int h = tubes_sections_scene(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, SECTION(c),
                                 c->pm_de[k], k, c->pm_n_seeds, c->pm_n_iter, c->pm_t_max, INTEGRATOR(c),
                                 dissipative(run), run->seeds);
    int r = record_emit(run->file, h);
    if (r == EXIT_IO || r == EXIT_NUMERIC) return r;
    if (r) rc = r;
    if (!dissipative(run)) continue;
    char name[32];
    snprintf(name, sizeof name, "sections/map_%03d", k);
    hid_t m = H5Gopen2(run->file, name, H5P_DEFAULT);
    int e = m < 0 || dissipation_attrs(m, run);
    if (m >= 0) H5Gclose(m);
    if (e) return EXIT_IO;
  }
  return rc;
}

/* ---------------------------------------------------------------- synthetic experiment */

/* n doubles of dataset path of file into v. Returns 0 or -1. */
static int read_doubles(hid_t file, const char *path, double *v) {
  hid_t d = H5Dopen2(file, path, H5P_DEFAULT);
  if (d < 0) return -1;
  herr_t r = H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
  H5Dclose(d);
  return r < 0 ? -1 : 0;
}

/* The file's /tracks (n = nt x ns frames) as CSV (header track,t,x,y; 12 significant digits),
 * written to path.tmp.<pid> and renamed when complete. Returns 0 or -1. */
static int write_tracks_csv(hid_t file, const char *path, int nt, int ns) {
  size_t n = (size_t)nt * ns;
  double *t = malloc(sizeof(double) * n), *x = malloc(sizeof(double) * n), *y = malloc(sizeof(double) * n);
  char tmp[TUBES_LPATH + 64];
  snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
  int e = !t || !x || !y || read_doubles(file, "tracks/t", t) || read_doubles(file, "tracks/x", x) ||
          read_doubles(file, "tracks/y", y);
  FILE *f = e ? NULL : fopen(tmp, "w");
  e = !f || fprintf(f, "track,t,x,y\n") < 0;
  for (size_t i = 0; i < n && !e; i++) e = fprintf(f, "%d,%.12g,%.12g,%.12g\n", (int)(i / ns), t[i], x[i], y[i]) < 0;
  if (f && fclose(f) != 0) e = 1;
  free(t); free(x); free(y);
  if (e || rename(tmp, path) != 0) {
    if (f) remove(tmp);
    return -1;
  }
  return 0;
}

int scene_synthetic_experiment(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  char method[32];
  snprintf(method, sizeof method, "%s", method_label(run));
  int h = tubes_synthetic_experiment_scene(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle,
                                           c->exp_n_tracks, c->exp_duration, c->exp_camera_rate, c->exp_pixel,
                                           c->exp_noise, c->exp_de_min, c->exp_de_max, c->exp_damping_ratio,
                                           c->exp_rolling_resistance, c->exp_seed, INTEGRATOR(c), method, run->seeds);
  int rc = record_emit(run->file, h);
  if (rc == EXIT_IO || !c->exp_csv[0] || run->rank != 0 || H5Lexists(run->file, "tracks", H5P_DEFAULT) <= 0)
    return rc;
  if (write_tracks_csv(run->file, c->exp_csv, c->exp_n_tracks,
                       tubes_experiment_samples(c->exp_duration, c->exp_camera_rate))) {
    fprintf(stderr, "tubes: synthetic_experiment: cannot write the CSV file '%s'\n", c->exp_csv);
    return EXIT_IO;
  }
  printf("  wrote %s (track,t,x,y)\n", c->exp_csv);
  return rc;
}

/* The normal form's results for /flux. */
typedef struct {
  int done, stat, n_nf, ndof;
  double lambda, omegas[MD - 1], diag[4];
  double *flux, *change, *coef;
  int *pw;        /* 3 per term: the powers of I_1, J_2, J_3 */
  double *nhim;   /* TUBES_NF_NPTS points z of the NHIM per energy (2N each), mapped from the normal form */
  double *round_trip, *energy_err;   /* per energy: the change's round trip; max |H(z) - E_s - dE| / dE */
  char msg[512];
  int nt, *ex;    /* the Taylor expansion at z the normal form came from: nt terms, 2N powers each */
  double *cf, z[2 * MD];
} nf_out_t;

/* The Birkhoff normal form of the formula model at the saddle (&flux order K; src/orbits/tubes_normal_form.f90)
 * and its flux on the &flux energies at orders K and K - 2, against the sampled flux fl +- fe:
 * a refusal (not a formula model: exit 1; degenerate, resonant: exit 2, the sampled flux still
 * written) or a disagreement beyond 5 combined standard errors (exit 2) is reported. */
static int flux_normal_form(const tubes_run_t *run, const double *fl, const double *fe, nf_out_t *o) {
  const tubes_config_t *c = run->cfg;
  int n = c->flux_nde, K = c->flux_order, nd = run->ndof;
  o->flux = calloc((size_t)n, sizeof(double));
  o->change = calloc((size_t)n, sizeof(double));
  o->round_trip = calloc((size_t)n, sizeof(double));
  o->energy_err = calloc((size_t)n, sizeof(double));
  o->nhim = calloc((size_t)n * TUBES_NF_NPTS * 2 * MD, sizeof(double));
  if (!o->flux || !o->change || !o->round_trip || !o->energy_err || !o->nhim) return EXIT_NUMERIC;
  for (int k = 0; k < n; k++) o->flux[k] = o->change[k] = o->round_trip[k] = o->energy_err[k] = NAN;
  if (nd == 3 && K > 10) {
    fprintf(stderr, "%s: &flux: order = %d: at most 10 in 3 degrees of freedom (the monomials grow as K^6)\n",
            run->input ? run->input : "tubes", K);
    return EXIT_BADINPUT;
  }
  eqlist_t L;
  int st = find_eqs(run, &L), ks = st ? -1 : find_named(&L, run->saddle);
  if (ks < 0) {
    fprintf(stderr, "tubes: flux: normal form: the saddle %s was not found again\n", run->saddle);
    return EXIT_NUMERIC;
  }
  double z[2 * MD];
  for (int i = 0; i < nd; i++) {
    z[i] = L.q[MD * ks + i];
    z[nd + i] = L.p[MD * ks + i];
  }
  double t0 = now();
  int nt = 0, *ex = NULL;
  double *cf = NULL;
  st = tubes_expr_taylor(run->system, z, K, &nt, &ex, &cf, o->msg, sizeof o->msg);
  memcpy(o->z, z, sizeof z);
  if (st) {
    fprintf(stderr, "%s: &flux: order = %d: %s\n", run->input ? run->input : "tubes", K, o->msg);
    return EXIT_BADINPUT;
  }
  int max_nf = 4096, *fst = calloc((size_t)n, sizeof(int)), n2 = 0, *pw2 = malloc(sizeof(int) * 3 * 4096);
  double *f2 = calloc((size_t)n, sizeof(double)), *c2 = malloc(sizeof(double) * 4096), lam2, om2[MD - 1], d2[4];
  char m2[512];
  o->coef = malloc(sizeof(double) * (size_t)max_nf);
  o->pw = malloc(sizeof(int) * 3 * (size_t)max_nf);
  int rc = 0;
  if (!fst || !f2 || !o->coef || !o->pw || !pw2 || !c2) {
    rc = EXIT_NUMERIC;
    goto out;
  }
  o->ndof = nd;
  o->stat = tubes_birkhoff(nd, K, nt, ex, cf, n, c->flux_de, o->flux, fst, &o->lambda, o->omegas, max_nf,
                              &o->n_nf, o->pw, o->coef, o->diag, o->nhim, o->round_trip, o->msg, sizeof o->msg);
  o->done = 1;
  if (o->stat) {
    fprintf(stderr, "tubes: flux: %s (status %d); the sampled flux is written\n", o->msg, o->stat);
    rc = EXIT_NUMERIC;
    goto out;
  }
  double *nh2 = malloc(sizeof(double) * (size_t)n * TUBES_NF_NPTS * 2 * MD), *rt2 = malloc(sizeof(double) * (size_t)n);
  if (K >= 4 && nh2 && rt2 && tubes_birkhoff(nd, K - 2, nt, ex, cf, n, c->flux_de, f2, fst + 0, &lam2, om2, 4096, &n2,
                                             pw2, c2, d2, nh2, rt2, m2, sizeof m2) == 0)
    for (int k = 0; k < n; k++) o->change[k] = fabs(o->flux[k] - f2[k]);
  free(nh2); free(rt2);
  /* the NHIM's points mapped to the model's coordinates: their energy by the model itself */
  for (int k = 0; k < n; k++) {
    double worst = 0;
    for (int j = 0; j < TUBES_NF_NPTS; j++) {
      double *d = o->nhim + ((size_t)k * TUBES_NF_NPTS + j) * 2 * nd, x[2 * MD], en;
      for (int i = 0; i < 2 * nd; i++) {
        x[i] = z[i] + d[i];
        d[i] = x[i];          /* stored as z itself */
      }
      if (tubes_energy(run->system, run->params, 2 * nd, x, &en) || !isfinite(en)) { worst = NAN; break; }
      worst = fmax(worst, fabs(en - L.en[ks] - c->flux_de[k]) / c->flux_de[k]);
    }
    o->energy_err[k] = isfinite(o->flux[k]) ? worst : NAN;
  }
  printf("flux: Birkhoff normal form of order %d at %s (%.2f s): lambda = %.10g, omega = %.10g", K, run->saddle,
         now() - t0, o->lambda, o->omegas[0]);
  if (nd == 3) printf(", %.10g", o->omegas[1]);
  printf("; checks: symplectic %.1e, non-normal terms left %.1e, imaginary %.1e, smallest divisor %.4g\n",
         o->diag[0], o->diag[1], o->diag[2], o->diag[3]);
  printf("  %10s %18s %12s %16s %12s %9s %12s %12s\n", "dE", "normal form", "change K-2", "sampled", "+-", "diff/sd",
         "NHIM dE err", "round trip");
  for (int k = 0; k < n; k++) {
    double z_;
    char vm[1024];
    int v = tubes_verdict_flux_normal_form(c->flux_de[k], K, o->flux[k], o->change[k], fl[k], fe[k], &z_, vm,
                                           sizeof vm);
    printf("  %10.4g %18.12g %12.3g %16.10g %12.4g %9.2f %12.3g %12.3g\n", c->flux_de[k], o->flux[k], o->change[k], fl[k],
           fe[k], z_, o->energy_err[k], o->round_trip[k]);
    if (v) {
      fprintf(stderr, "%s\n", vm);
      rc = EXIT_NUMERIC;
    }
  }
out:
  o->nt = nt;          /* kept for the tube's cut (section_fraction) */
  o->ex = ex;
  o->cf = cf;
  free(fst); free(f2); free(c2); free(pw2);
  return rc;
}

/* The &section plane q_k = c: the energy surface's volume on it (sampled as the flux) and the
 * fraction of it that transits before returning, against flux / volume (the normal form's flux
 * when there is one, else the sampled). More than 1 % undecided, or the two more than 5 combined
 * standard errors apart: reported, exit 2. */
static int section_fraction(const tubes_run_t *run, const double *fl, const double *fe, const double *fnf,
                            const double *fch, double *sv, double *sve, double *sf, double *sfe, double *pth,
                            double *sx, double *sw, int *scls, int *counts) {
  const tubes_config_t *c = run->cfg;
  int n = c->flux_nde, rc = 0, ns = c->flux_n_samples;
  printf("flux: the transition fraction on the section q%d = %g (dq%d/dt %s 0): Monte Carlo (%d points) against "
         "flux / volume\n", c->sec_index, c->sec_value, c->sec_index, c->sec_direction > 0 ? ">" : "<",
         c->flux_n_samples);
  printf("  %10s %14s %10s %12s %12s %10s %9s %9s %9s %9s\n", "dE", "volume", "+-", "flux/volume", "Monte Carlo",
         "+-", "diff/sd", "transits", "returns", "undecided");
  for (int k = 0; k < n; k++) {
    int *cnt = counts + 4 * k;   /* inside the shell, transits, returns, undecided */
    double t0 = now();
    int st = tubes_section_transit(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle,
                                   c->flux_de[k], c->sec_index, c->sec_value, c->sec_direction, c->flux_n_samples,
                                   c->flux_seed, c->flux_t_max, c->flux_gate, c->flux_tol, INTEGRATOR(c), &sv[k],
                                   &sve[k], &sf[k], &sfe[k], cnt, sx + (size_t)k * ns * 2 * MD,
                                   sw + (size_t)k * ns, scls + (size_t)k * ns);
    if (st < 0) {
      char m[TUBES_LSTATUS];
      status_text(st, m, sizeof m);
      fprintf(stderr, "tubes: flux: the section q%d = %g at dE = %g: %s (status %d)%s\n", c->sec_index, c->sec_value,
              c->flux_de[k], m, st, st == TUBES_EOUTSIDE ? ": the section's point nearest the saddle lies outside "
              "the energy surface (a section the tube cannot reach there: move it)" : "");
      sv[k] = sve[k] = sf[k] = sfe[k] = pth[k] = NAN;
      rc = EXIT_NUMERIC;
      continue;
    }
    /* flux / volume, the normal form's flux where its own error (the change from order K - 2) is
     * within 10 % of it, beyond its reach (4.48 at dE = 1e6, order 4) the sampled flux; against the
     * Monte Carlo fraction (tubes_verdicts.f90 section_check) */
    double z;
    int use_nf;
    char vm[1024];
    int v = tubes_verdict_section(c->flux_de[k], fnf ? fnf[k] : NAN, fch ? fch[k] : NAN, fl[k], fe[k], sv[k], sve[k],
                                  sf[k], sfe[k], ns, sw + (size_t)k * ns, cnt, c->flux_t_max, &use_nf, &pth[k], &z,
                                  vm, sizeof vm);
    if (fnf && isfinite(fnf[k]) && !use_nf && isfinite(fl[k]))
      printf("  (dE = %g: flux / volume from the sampled flux: the normal form's change from order K - 2, %.3g, "
             "exceeds 10 %% of its flux %.6g)\n", c->flux_de[k], fch[k], fnf[k]);
    if (isnan(pth[k])) {   /* no flux there (failed, past the bottleneck, or too small) */
      printf("  %10.4g %14.8g %10.3g %12s %12.6f %10.2g %9s %9d %9d %9d   (%.1f s)\n", c->flux_de[k], sv[k], sve[k],
             "-", sf[k], sfe[k], "-", cnt[1], cnt[2], cnt[3], now() - t0);
      continue;
    }
    printf("  %10.4g %14.8g %10.3g %12.6f %12.6f %10.2g %9.2f %9d %9d %9d   (%.1f s)\n", c->flux_de[k], sv[k], sve[k],
           pth[k], sf[k], sfe[k], z, cnt[1], cnt[2], cnt[3], now() - t0);
    if (v) {
      fprintf(stderr, "%s\n", vm);
      rc = EXIT_NUMERIC;
    }
  }
  return rc;
}

/* The tube's cut on the section (3 DOF, a normal form, &flux n_cut > 0): per energy. */
typedef struct {
  int n, nodes, ns, axes[4];
  double *x, *t, *diag, *ptrans, *sx, *sw;   /* nodes' states (6 each), times; diag 4 per energy */
  double *vex;                                /* the volume extrapolated from the grid and its half */
  int *st, *inside, *inside_pl, *scls, *mis, *mis_pl, *unres;
} cut_out_t;

/* The cut of the stable tube with the section q_k = c (src/orbits/tubes_cut3.f90): its 4-volume against
 * the flux, and the Monte Carlo points of section_fraction inside it against their fate. The cut
 * on every other node gives a second volume V_h: the discretisation is second order, so
 * V_x = V + (V - V_h) / 3 is the extrapolated volume. The piecewise-linear cut lacks about
 * |V_x - V|: the decided points in that shell, mu = n_decided |V_x - V| / (the section's volume),
 * are those its resolution may misclassify. Reported with exit 2: a seed that never reaches the
 * section; V_x further from the flux than a quarter of |V - V_h| (plus 1e-6 relative); more
 * misclassified points (by the smooth cut) than mu + 5 sqrt(mu) + 2. */
static int tube_cut3(const tubes_run_t *run, const nf_out_t *o, const double *sv, cut_out_t *u) {
  const tubes_config_t *c = run->cfg;
  int n = c->flux_nde, rc = 0, m = TUBES_CUT3_NODES(c->flux_n_cut), ns = u->ns;
  int k3 = c->sec_index, a = k3 == 1 ? 2 : 1, b = 6 - k3 - a;
  int ax[4] = {a, 3 + a, b, 3 + b};
  memcpy(u->axes, ax, sizeof ax);
  u->n = n;
  u->nodes = m;
  u->x = malloc(sizeof(double) * 6 * (size_t)m * n);
  u->t = malloc(sizeof(double) * (size_t)m * n);
  u->st = malloc(sizeof(int) * (size_t)m * n);
  u->diag = malloc(sizeof(double) * TUBES_CUT3_NDIAG * (size_t)n);
  u->ptrans = malloc(sizeof(double) * (size_t)n);
  u->vex = malloc(sizeof(double) * (size_t)n);
  u->inside = malloc(sizeof(int) * ((size_t)ns * n + 1));
  u->inside_pl = malloc(sizeof(int) * ((size_t)ns * n + 1));
  u->mis = malloc(sizeof(int) * (size_t)n);
  u->mis_pl = malloc(sizeof(int) * (size_t)n);
  u->unres = malloc(sizeof(int) * (size_t)n);
  if (!u->x || !u->t || !u->st || !u->diag || !u->ptrans || !u->vex || !u->inside || !u->inside_pl || !u->mis ||
      !u->mis_pl || !u->unres)
    return EXIT_NUMERIC;
  printf("flux: the stable tube's cut with the section q%d = %g: a 3-sphere from %d NHIM seeds (%d rings of "
         "%d x %d, step-off %g); its 4-volume against the flux, the Monte Carlo points inside it against their fate\n",
         k3, c->sec_value, m, c->flux_n_cut + 1, 2 * c->flux_n_cut, 2 * c->flux_n_cut, c->flux_cut_eps);
  printf("  %10s %13s %13s %13s %11s %11s %12s %12s %8s %8s %11s %9s %10s\n", "dE", "cut volume", "extrapolated",
         "flux", "extrap/f-1", "seed dE err", "p_trans tube", "Monte Carlo", "inside", "decided", "misclass PL",
         "misclass", "unresolved");
  for (int k = 0; k < n; k++) {
    double t0 = now(), *d = u->diag + TUBES_CUT3_NDIAG * k, *sx = u->sx + (size_t)k * ns * 2 * MD, *sw = u->sw + (size_t)k * ns;
    int *ins = u->inside + (size_t)k * ns, *inh = u->inside_pl + (size_t)k * ns, *cls = u->scls + (size_t)k * ns;
    char msg[256] = "";
    u->mis[k] = u->mis_pl[k] = u->unres[k] = -1;
    u->ptrans[k] = u->vex[k] = NAN;
    progress_item("flux: the tube's cut at dE = %g (%d of %d)...\n", c->flux_de[k], k + 1, n);
    int st = tubes_tube_cut3(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, c->flux_order,
                             o->nt, o->ex, o->cf, o->z, c->flux_de[k], c->sec_index, c->sec_value, c->sec_direction,
                             c->flux_n_cut, c->flux_cut_eps, c->flux_t_max, c->flux_tol, INTEGRATOR(c), ns, sx, sw, cls,
                             ins, inh, u->x + 6 * (size_t)m * k, u->t + (size_t)m * k, u->st + (size_t)m * k, d, msg,
                             sizeof msg);
    if (st < 0) {
      int nf[3] = {0, 0, 0};
      for (int j = 0; j < m; j++) {
        int s = u->st[(size_t)m * k + j];
        nf[s == 1 ? 0 : s == 2 ? 1 : 2] += s != 0;
      }
      if (st == TUBES_ENOCROSS && nf[1] == m)
        fprintf(stderr, "tubes: flux: the tube's cut at dE = %g: the stable tube reaches the section q%d = %g with "
                "dq%d/dt %s 0, and &section direction = %d asks for the other way: set direction = %d\n",
                c->flux_de[k], k3, c->sec_value, k3, c->sec_direction > 0 ? "<" : ">", c->sec_direction,
                -c->sec_direction);
      else if (st == TUBES_ENOCROSS)
        fprintf(stderr, "tubes: flux: the tube's cut at dE = %g: of %d seeds, %d did not reach the section q%d = %g "
                "within t_max = %g, %d crossed it the other way first, %d failed: the tube does not reach this "
                "section as a whole (move it nearer the saddle, or raise &flux t_max)\n", c->flux_de[k], m, nf[0],
                k3, c->sec_value, c->flux_t_max, nf[1], nf[2]);
      else
        fprintf(stderr, "tubes: flux: the tube's cut at dE = %g: %s (status %d)\n", c->flux_de[k],
                msg[0] ? msg : "failed", st);
      rc = EXIT_NUMERIC;
      continue;
    }
    /* d: seed error, V, failed, V_h, V_x, unresolved, misclassified, by the linear cut, decided, inside,
     * p_trans of the tube, of the Monte Carlo */
    int ndec = (int)d[8], nin = (int)d[9], mis = (int)d[6], mispl = (int)d[7];
    double f = o->flux[k], mc = d[11];
    u->mis[k] = mis;
    u->mis_pl[k] = mispl;
    u->unres[k] = (int)d[5];
    u->ptrans[k] = d[10];
    u->vex[k] = d[4];
    printf("  %10.4g %13.8g %13.8g %13.8g %11.2e %11.2e %12.6f %12.6f %8d %8d %11d %9d %10d   (%.1f s)\n",
           c->flux_de[k], d[1], u->vex[k], f, u->vex[k] / f - 1, d[0], u->ptrans[k], mc, nin, ndec, mispl, mis,
           u->unres[k], now() - t0);
    char vm[1024];
    if (tubes_verdict_cut3(c->flux_de[k], d[1], d[3], u->vex[k], f, sv[k], ndec, mis, vm, sizeof vm)) {
      fprintf(stderr, "%s\n", vm);
      rc = EXIT_NUMERIC;
    }
  }
  return rc;
}

static int write_tube_cut3(hid_t g, const cut_out_t *u, const tubes_config_t *c) {
  hid_t h = h5_group(g, "tube_cut");
  if (h < 0) return 1;
  int nc = (int)lround(cbrt(u->nodes / 4.0));   /* nodes = (n_cut + 1) 4 n_cut^2 */
  while (TUBES_CUT3_NODES(nc) < u->nodes) nc++;
  while (TUBES_CUT3_NODES(nc) > u->nodes) nc--;
  hsize_t dx[5] = {(hsize_t)u->n, (hsize_t)nc + 1, 2 * (hsize_t)nc, 2 * (hsize_t)nc, 6};
  hsize_t dn = (hsize_t)u->n, dd[2] = {(hsize_t)u->n, 3}, dp[3] = {(hsize_t)u->n, (hsize_t)u->ns, 6},
          ds[2] = {(hsize_t)u->n, (hsize_t)u->ns};
  double *sec = malloc(sizeof(double) * 4 * (size_t)u->nodes * u->n);
  double *px = malloc(sizeof(double) * 6 * ((size_t)u->ns * u->n + 1));
  double *vol = malloc(sizeof(double) * (size_t)u->n), *een = malloc(sizeof(double) * (size_t)u->n);
  int e = !sec || !px || !vol || !een;
  for (size_t j = 0; !e && j < (size_t)u->nodes * u->n; j++)
    for (int i = 0; i < 4; i++) sec[4 * j + i] = u->x[6 * j + u->axes[i] - 1];
  for (size_t j = 0; !e && j < (size_t)u->ns * u->n; j++)
    for (int i = 0; i < 6; i++) px[6 * j + i] = u->sx[2 * MD * j + i];
  double *vh = malloc(sizeof(double) * (size_t)u->n);
  e |= !vh;
  for (int k = 0; !e && k < u->n; k++) {
    vol[k] = u->diag[TUBES_CUT3_NDIAG * k + 1];
    een[k] = u->diag[TUBES_CUT3_NDIAG * k];
    vh[k] = u->diag[TUBES_CUT3_NDIAG * k + 3];
  }
  if (!e) {
    e |= h5_write_double(h, "states", 5, dx, u->x, "state units");
    dx[4] = 4;
    e |= h5_write_double(h, "section", 5, dx, sec, "state units");
    e |= h5_write_double(h, "time", 4, dx, u->t, NULL);
    e |= h5_write_int_nd(h, "status", 4, dx, u->st, NULL);
    e |= h5_write_double(h, "volume", 1, &dn, vol, NULL);
    e |= h5_write_double(h, "volume_half", 1, &dn, vh, NULL);
    e |= h5_write_double(h, "seed_energy_error", 1, &dn, een, NULL);
    e |= h5_write_double(h, "p_trans_tube", 1, &dn, u->ptrans, NULL);
    e |= h5_write_int(h, "misclassified", dn, u->mis, NULL);
    e |= h5_write_int(h, "misclassified_pl", dn, u->mis_pl, NULL);
    e |= h5_write_int(h, "unresolved", dn, u->unres, NULL);
    e |= h5_write_double(h, "volume_extrapolated", 1, &dn, u->vex, NULL);
    if (u->ns > 0) {    /* the section's Monte Carlo points (natural models) */
      e |= h5_write_double(h, "points", 3, dp, px, "state units");
      e |= h5_write_double(h, "weight", 2, ds, u->sw, NULL);
      e |= h5_write_int_nd(h, "outcome", 2, ds, u->scls, NULL);
      e |= h5_write_int_nd(h, "inside", 2, ds, u->inside, NULL);
      e |= h5_write_int_nd(h, "inside_pl", 2, ds, u->inside_pl, NULL);
    }
    e |= h5_attr_long(h, "section_index", c->sec_index);
    e |= h5_attr_double(h, "section_value", c->sec_value);
    e |= h5_attr_long(h, "section_direction", c->sec_direction);
    e |= h5_attr_double(h, "cut_eps", c->flux_cut_eps);
    char axes[64];
    snprintf(axes, sizeof axes, "q%d p%d q%d p%d", u->axes[0], u->axes[0], u->axes[2], u->axes[2]);
    e |= h5_attr_string(h, "axes", axes);
    e |= h5_attr_long(h, "n_cut", nc);
  }
  (void)dd;
  free(sec); free(px); free(vol); free(een); free(vh);
  H5Gclose(h);
  return e;
}

static int write_normal_form(hid_t g, const nf_out_t *o, int n) {
  hsize_t dn = (hsize_t)n;
  int e = h5_write_double(g, "flux_normal_form", 1, &dn, o->flux, NULL);
  e |= h5_write_double(g, "flux_normal_form_change", 1, &dn, o->change, NULL);
  e |= h5_write_double(g, "nhim_energy_error", 1, &dn, o->energy_err, NULL);
  e |= h5_write_double(g, "round_trip_error", 1, &dn, o->round_trip, NULL);
  e |= h5_attr_long(g, "normal_form_status", o->stat);
  e |= h5_attr_string(g, "normal_form_message", o->msg);
  if (!o->done || o->stat) return e;
  hid_t h = h5_group(g, "normal_form");
  if (h < 0) return 1;
  hsize_t nm = (hsize_t)(o->ndof - 1), nt = (hsize_t)o->n_nf;
  e |= h5_attr_double(h, "lambda", o->lambda);
  e |= h5_write_double(h, "omegas", 1, &nm, o->omegas, NULL);
  e |= h5_attr_double(h, "symplectic_error", o->diag[0]);
  e |= h5_attr_double(h, "residual", o->diag[1]);
  e |= h5_attr_double(h, "imaginary", o->diag[2]);
  e |= h5_attr_double(h, "smallest_divisor", o->diag[3]);
  e |= h5_write_double(h, "coefficients", 1, &nt, o->coef, NULL);
  hsize_t dp[3] = {(hsize_t)n, TUBES_NF_NPTS, (hsize_t)(2 * o->ndof)};
  e |= h5_write_double(h, "nhim_points", 3, dp, o->nhim, "state units");
  int *col = malloc(sizeof(int) * (o->n_nf ? (size_t)o->n_nf : 1));
  static const char *const names[3] = {"power_I1", "power_J2", "power_J3"};
  for (int j = 0; col && j < o->ndof; j++) {
    for (int t = 0; t < o->n_nf; t++) col[t] = o->pw[3 * t + j];
    e |= h5_write_int(h, names[j], nt, col, NULL);
  }
  e |= !col;
  free(col);
  H5Gclose(h);
  return e;
}

/* The flux through the bottleneck on the &flux energies: sampled on the dividing surface (every
 * rank samples every energy: the same numbers), beside the leading-order formula. A sample whose
 * future or past stays near the saddle to t_max is undecided; more than 1 % of the points inside
 * the shell undecided is a failure (t_max too short for the slab), reported with exit 2. */
int scene_flux(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int n = c->flux_nde, rc = 0;
  double *fl = calloc(n, sizeof(double)), *fe = calloc(n, sizeof(double)), *lo = calloc(n, sizeof(double));
  int *cnt = calloc(4 * (size_t)n, sizeof(int)), *stat = calloc(n, sizeof(int));
  if (!fl || !fe || !lo || !cnt || !stat) {
    free(fl); free(fe); free(lo); free(cnt); free(stat);
    fprintf(stderr, "tubes: flux: out of memory\n");
    return EXIT_NUMERIC;
  }
  printf("flux: through the bottleneck of %s, N = %d: sampled on the dividing surface (%d points, slab "
         "half-width %g, tol %g), beside the leading order (2 pi)^(N-1) dE^(N-1) / ((N-1)! prod omega)\n",
         run->saddle, run->ndof, c->flux_n_samples, c->flux_gate, c->flux_tol);
  printf("  %10s %16s %12s %16s %9s %9s %9s %9s\n", "dE", "flux", "+-", "leading", "flux/lead", "reacting",
         "recross", "undecided");
  int sampled = 1;   /* H quadratic in the momenta (natural or gyroscopic): else the normal form alone */
  for (int k = 0; k < n && sampled; k++) {
    double de = c->flux_de[k], box[2 * (MD - 1)], t0 = now();
    progress_item("flux: dE = %g (%d of %d)...\n", de, k + 1, n);
    int st = tubes_flux_sample(run->system, run->params, run->lo, run->hi, run->n_grid, run->saddle, de, c->flux_n_samples,
                        c->flux_seed, c->flux_t_max, c->flux_gate, c->flux_tol, INTEGRATOR(c), &fl[k], &fe[k], &lo[k],
                        cnt + 4 * k, box);
    stat[k] = st;
    int *ct = cnt + 4 * k;
    if (st == TUBES_EINPUT && !run->natural) {
      printf("  (not sampled: H is not quadratic in the momenta, or has no reversor to pair each crossing with "
             "its time-reverse; the normal form's flux only)\n");
      for (int j = 0; j < n; j++) fl[j] = fe[j] = lo[j] = NAN;
      sampled = 0;
      if (c->flux_order == 0) {
        fprintf(stderr, "tubes: flux: the Hamiltonian of '%s' is not quadratic in the momenta or has no reversor "
                "(a time-reversal symmetry): the dividing surface cannot be sampled; give &flux order (the normal "
                "form's flux, for a model written as a formula)\n", c->system);
        rc = EXIT_NUMERIC;
      }
      break;
    }
    if (st < 0) {
      char m[TUBES_LSTATUS];
      status_text(st, m, sizeof m);
      fl[k] = fe[k] = NAN;
      if (st == TUBES_EPASTEND) {   /* the dividing surface passes over a ridge: no single bottleneck */
        fprintf(stderr, "tubes: flux: dE = %g is past the bottleneck of %s: the dividing surface's {V <= E} runs "
                "over a ridge into another well or neck (the energy is above a maximum of V beside the saddle, "
                "where its orbit family ends), so its flux is not the bottleneck's; NaN there\n", de, run->saddle);
        if (!rc) rc = EXIT_PARTIAL;
        continue;
      }
      fprintf(stderr, "tubes: flux: dE = %g failed: %s (status %d)\n", de, m, st);
      rc = EXIT_NUMERIC;
      continue;
    }
    char vm[1024];
    if (tubes_verdict_flux_too_small(de, run->ndof, lo[k], vm, sizeof vm)) {   /* below the smallest double */
      fprintf(stderr, "%s\n", vm);
      fl[k] = fe[k] = NAN;
      rc = EXIT_NUMERIC;
      continue;
    }
    printf("  %10.4g %16.10g %12.4g %16.10g %9.6f %9d %9d %9d   (%.1f s)\n", de, fl[k], fe[k], lo[k], fl[k] / lo[k],
           ct[1], ct[2], ct[3], now() - t0);
    if (tubes_verdict_flux_undecided(de, ct, c->flux_gate, c->flux_t_max, vm, sizeof vm)) {
      fprintf(stderr, "%s\n", vm);
      rc = EXIT_NUMERIC;
    }
  }
  /* the normal form (&flux order > 0): its flux at order K and K - 2 (the change: its own error
   * estimate), and the check against the sampled flux */
  nf_out_t nfo;
  memset(&nfo, 0, sizeof nfo);
  if (c->flux_order > 0) {
    int r2 = flux_normal_form(run, fl, fe, &nfo);
    if (r2 && (!rc || r2 == EXIT_BADINPUT)) rc = r2;
  }
  /* the transition fraction on a plane section: Monte Carlo against flux / volume */
  /* 2 DOF: the transition scene. A model not quadratic in the momenta: the tube's cut without Monte Carlo */
  int sec = sampled && run->ndof == 3 && !strcmp(c->sec_kind, "plane");
  int cut_only = !sampled && run->ndof == 3 && !strcmp(c->sec_kind, "plane");
  double *sv = calloc((size_t)n, sizeof(double)), *sve = calloc((size_t)n, sizeof(double)),
         *sf = calloc((size_t)n, sizeof(double)), *sfe = calloc((size_t)n, sizeof(double)),
         *pth = calloc((size_t)n, sizeof(double));
  cut_out_t cut;
  memset(&cut, 0, sizeof cut);
  int *scnt = calloc(4 * (size_t)n + 1, sizeof(int));
  cut.ns = c->flux_n_samples;
  if (sec) {
    cut.sx = malloc(sizeof(double) * 2 * MD * (size_t)n * cut.ns);
    cut.sw = malloc(sizeof(double) * (size_t)n * cut.ns);
    cut.scls = malloc(sizeof(int) * (size_t)n * cut.ns);
  }
  if (sec && sv && sve && sf && sfe && pth && cut.sx && cut.sw && cut.scls && scnt) {
    int r3 = section_fraction(run, fl, fe, nfo.flux, nfo.change, sv, sve, sf, sfe, pth, cut.sx, cut.sw, cut.scls,
                              scnt);
    if (r3 && !rc) rc = r3;
    /* the tube's cut: a normal form (its coordinates seed the tube) with every energy's flux */
    int cutok = c->flux_n_cut > 0 && nfo.done && nfo.stat == 0 && nfo.ex;
    for (int k = 0; cutok && k < n; k++) cutok = isfinite(nfo.flux[k]) && isfinite(sv[k]);
    if (cutok) {
      int r4 = tube_cut3(run, &nfo, sv, &cut);
      if (r4 && !rc) rc = r4;
    } else if (c->flux_n_cut > 0) {
      printf("  (no tube cut: it is seeded from the normal form, which needs &flux order and a flux at every dE)\n");
    }
  } else if (cut_only && c->flux_n_cut > 0 && sv) {
    int cutok = nfo.done && nfo.stat == 0 && nfo.ex;
    for (int k = 0; cutok && k < n; k++) cutok = isfinite(nfo.flux[k]);
    cut.ns = 0;
    cut.sx = malloc(sizeof(double) * 2 * MD);
    cut.sw = malloc(sizeof(double));
    cut.scls = malloc(sizeof(int));
    if (cutok && cut.sx && cut.sw && cut.scls) {
      for (int k = 0; k < n; k++) sv[k] = NAN;
      printf("  (the section's Monte Carlo needs H quadratic in the momenta: the tube's cut alone)\n");
      int r4 = tube_cut3(run, &nfo, sv, &cut);
      if (r4 && !rc) rc = r4;
    } else {
      printf("  (no tube cut: it is seeded from the normal form, which needs &flux order and a flux at every dE)\n");
    }
  }
  hid_t g = h5_group(run->file, "flux");
  int e = g < 0;
  hsize_t dn = (hsize_t)n;
  int *nin = malloc(sizeof(int) * (n ? n : 1)), *nre = malloc(sizeof(int) * (n ? n : 1)),
      *nrc = malloc(sizeof(int) * (n ? n : 1)), *nun = malloc(sizeof(int) * (n ? n : 1));
  for (int k = 0; nin && nre && nrc && nun && k < n; k++) {
    nin[k] = cnt[4 * k]; nre[k] = cnt[4 * k + 1]; nrc[k] = cnt[4 * k + 2]; nun[k] = cnt[4 * k + 3];
  }
  e |= !nin || !nre || !nrc || !nun;
  if (!e) {
    e |= h5_write_double(g, "dE", 1, &dn, c->flux_de, NULL);
    e |= h5_write_double(g, "flux_sampled", 1, &dn, fl, NULL);
    e |= h5_write_double(g, "flux_sampled_err", 1, &dn, fe, NULL);
    e |= h5_write_double(g, "flux_leading_order", 1, &dn, lo, NULL);
    e |= h5_write_int(g, "n_inside", dn, nin, NULL);
    e |= h5_write_int(g, "n_reacting", dn, nre, NULL);
    e |= h5_write_int(g, "n_recrossing", dn, nrc, NULL);
    e |= h5_write_int(g, "n_undecided", dn, nun, NULL);
    e |= h5_write_int(g, "status", dn, stat, NULL);
    e |= h5_attr_long(g, "n_samples", c->flux_n_samples);
    e |= h5_attr_long(g, "seed", c->flux_seed);
    e |= h5_attr_double(g, "t_max", c->flux_t_max);
    e |= h5_attr_double(g, "gate", c->flux_gate);
    e |= h5_attr_double(g, "tol", c->flux_tol);
    e |= h5_attr_string(g, "saddle", run->saddle);
    e |= h5_attr_long(g, "order", c->flux_order);
    if (c->flux_order > 0) e |= write_normal_form(g, &nfo, n);
    if (sec) {
      hid_t s3 = h5_group(g, "section");    /* the transition fraction on the 4-D section */
      int *col = malloc(sizeof(int) * (n ? (size_t)n : 1));
      e |= s3 < 0 || !col;
      if (s3 >= 0 && col) {
        e |= h5_write_double(s3, "volume", 1, &dn, sv, NULL);
        e |= h5_write_double(s3, "volume_err", 1, &dn, sve, NULL);
        e |= h5_write_double(s3, "p_trans", 1, &dn, sf, NULL);
        e |= h5_write_double(s3, "p_trans_err", 1, &dn, sfe, NULL);
        e |= h5_write_double(s3, "p_trans_theory", 1, &dn, pth, NULL);
        static const char *const cn[4] = {"n_inside", "n_transit", "n_return", "n_undecided"};
        for (int j = 0; j < 4; j++) {
          for (int k = 0; k < n; k++) col[k] = scnt[4 * k + j];
          e |= h5_write_int(s3, cn[j], dn, col, NULL);
        }
        e |= h5_attr_long(s3, "index", c->sec_index);
        e |= h5_attr_double(s3, "value", c->sec_value);
        e |= h5_attr_long(s3, "direction", c->sec_direction);
      }
      free(col);
      if (s3 >= 0) H5Gclose(s3);
    }
    if (cut.mis) e |= write_tube_cut3(g, &cut, c);
  }
  if (g >= 0) H5Gclose(g);
  free(fl); free(fe); free(lo); free(cnt); free(stat); free(nin); free(nre); free(nrc); free(nun);
  free(nfo.flux); free(nfo.change); free(nfo.coef); free(nfo.pw); free(nfo.nhim); free(nfo.round_trip);
  free(nfo.energy_err); free(sv); free(sve); free(sf); free(sfe); free(pth); free(nfo.ex); free(nfo.cf);
  free(cut.x); free(cut.t); free(cut.st); free(cut.diag); free(cut.ptrans); free(cut.inside); free(cut.mis);
  free(cut.vex); free(cut.inside_pl); free(cut.mis_pl); free(cut.unres);
  free(cut.sx); free(cut.sw); free(cut.scls); free(scnt);
  return e ? EXIT_IO : rc;
}
