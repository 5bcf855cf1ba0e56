/* GSL quadrature, root finding and periodic splines for the Fortran core (src/transport/tubes_ray_surface.f90,
 * src/orbits/tubes_manifold.f90). The integrands are Fortran bind(C) callbacks with a user pointer; no
 * state outside the call (workspaces are allocated per call), so calls are thread-safe. GSL's
 * error handler is switched off (once) so that failures come back as status codes. */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>
#include <gsl/gsl_roots.h>
#include <gsl/gsl_spline.h>

typedef double (*tubes_quad_fn)(double x, void *user);

static pthread_once_t once = PTHREAD_ONCE_INIT;
static void handler_off(void) { gsl_set_error_handler_off(); }

typedef struct { tubes_quad_fn f; void *user; } wrap_t;
static double call(double x, void *p) { wrap_t *w = p; return w->f(x, w->user); }

/* Adaptive Gauss-Kronrod with extrapolation (QAGS) of f over [a, b]. Returns the GSL status. */
int tubes_quad_qags(tubes_quad_fn f, void *user, double a, double b, double epsabs, double epsrel,
                    double *result, double *abserr) {
  pthread_once(&once, handler_off);
  gsl_integration_workspace *ws = gsl_integration_workspace_alloc(1000);
  if (!ws) return GSL_ENOMEM;
  wrap_t w = {f, user};
  gsl_function F = {call, &w};
  int st = gsl_integration_qags(&F, a, b, epsabs, epsrel, 1000, ws, result, abserr);
  gsl_integration_workspace_free(ws);
  return st;
}

/* Brent's method for f(x) = 0 in the bracket [a, b]: |b - a| <= epsabs + epsrel |x|. */
int tubes_quad_root(tubes_quad_fn f, void *user, double a, double b, double epsabs, double epsrel,
                    double *root) {
  pthread_once(&once, handler_off);
  wrap_t w = {f, user};
  gsl_function F = {call, &w};
  gsl_root_fsolver *s = gsl_root_fsolver_alloc(gsl_root_fsolver_brent);
  if (!s) return GSL_ENOMEM;
  int st = gsl_root_fsolver_set(s, &F, a, b);
  for (int it = 0; st == GSL_SUCCESS && it < 200; it++) {
    st = gsl_root_fsolver_iterate(s);
    if (st != GSL_SUCCESS) break;
    double lo = gsl_root_fsolver_x_lower(s), hi = gsl_root_fsolver_x_upper(s);
    *root = gsl_root_fsolver_root(s);
    if (gsl_root_test_interval(lo, hi, epsabs, epsrel) == GSL_SUCCESS) break;
    if (it == 199) st = GSL_EMAXITER;
  }
  gsl_root_fsolver_free(s);
  return st;
}

/* Green's theorem on a closed curve sampled at n parameter values tau[0] < ... < tau[n-1] of
 * period `period` (the point at tau[0] + period is the first one again): periodic cubic splines
 * r(tau), p(tau), and area = integral of p r' dtau (degree 5 per interval: 3-point Gauss-Legendre
 * is exact). Returns 0, or a GSL status. */
int tubes_spline_area(int n, const double *tau, const double *r, const double *p, double period,
                      double *area) {
  pthread_once(&once, handler_off);
  if (n < 3) return GSL_EINVAL;
  double *tt = malloc(sizeof(double) * (n + 1)), *rr = malloc(sizeof(double) * (n + 1)),
         *pp = malloc(sizeof(double) * (n + 1));
  if (!tt || !rr || !pp) { free(tt); free(rr); free(pp); return GSL_ENOMEM; }
  for (int i = 0; i < n; i++) { tt[i] = tau[i]; rr[i] = r[i]; pp[i] = p[i]; }
  tt[n] = tau[0] + period; rr[n] = r[0]; pp[n] = p[0];
  gsl_interp_accel *acc = gsl_interp_accel_alloc();
  gsl_spline *sr = gsl_spline_alloc(gsl_interp_cspline_periodic, n + 1);
  gsl_spline *sp = gsl_spline_alloc(gsl_interp_cspline_periodic, n + 1);
  int st = (acc && sr && sp) ? GSL_SUCCESS : GSL_ENOMEM;
  if (st == GSL_SUCCESS) st = gsl_spline_init(sr, tt, rr, n + 1);
  if (st == GSL_SUCCESS) st = gsl_spline_init(sp, tt, pp, n + 1);
  if (st == GSL_SUCCESS) {
    const double g = sqrt(0.6), wq[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9}, xq[3] = {-g, 0.0, g};
    double sum = 0;
    for (int i = 0; i < n; i++) {
      double a = tt[i], b = tt[i + 1], m = 0.5 * (a + b), hl = 0.5 * (b - a);
      for (int k = 0; k < 3; k++) {
        double x = m + hl * xq[k];
        sum += wq[k] * hl * gsl_spline_eval(sp, x, acc) * gsl_spline_eval_deriv(sr, x, acc);
      }
    }
    *area = sum;
  }
  if (sr) gsl_spline_free(sr);
  if (sp) gsl_spline_free(sp);
  if (acc) gsl_interp_accel_free(acc);
  free(tt); free(rr); free(pp);
  return st;
}

#include <gsl/gsl_rng.h>

int tubes_cancel_requested(void);   /* include/tubes.h: Ctrl-C in Python */

/* n uniform deviates in [0, 1) from GSL's MT19937 seeded with `seed`: one stream, drawn
 * serially, so that the samples do not depend on how the work is later shared out. GSL_EFAILED
 * when the caller asked to stop (8 x 10^7 deviates take a second). */
int tubes_rng_uniform(unsigned long seed, int n, double *u) {
  gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
  if (!r) return GSL_ENOMEM;
  gsl_rng_set(r, seed);
  for (int i = 0; i < n; i++) {
    if (!(i & 0xfffff) && tubes_cancel_requested()) {
      gsl_rng_free(r);
      return GSL_EFAILED;
    }
    u[i] = gsl_rng_uniform(r);
  }
  gsl_rng_free(r);
  return 0;
}
