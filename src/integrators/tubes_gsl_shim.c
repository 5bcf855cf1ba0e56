/* C shim between src/integrators/tubes_gsl.f90 and GSL odeiv2 (gsl_rk8pd, gsl_rk4imp backends).
 *
 * GSL has no Fortran interface and its objects are C structs, so this file owns them: one
 * tubes_gsl_work per integrator instance holds the gsl_odeiv2_system and a driver (which
 * allocates the stepper, the y_new control and the evolve object, and links them: rk4imp needs
 * the driver to read the error levels). The Fortran side steps with gsl_odeiv2_evolve_apply
 * through tubes_gsl_shim_apply. No state lives outside tubes_gsl_work, except GSL's own
 * process-wide error handler, which is switched off once (pthread_once): GSL would otherwise
 * abort() the process on an internal error (e.g. a singular Newton matrix in rk4imp); with it
 * off every error comes back as a status code.
 *
 * The Fortran callbacks speak the tubes convention (0 ok, > 0 recoverable: try a smaller step,
 * < 0 fatal); the wrappers below translate to GSL's (GSL_SUCCESS, GSL_FAILURE: evolve halves the
 * step, GSL_EBADFUNC: evolve stops at once).
 */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

/* f(t, y) -> dydt; the Jacobian fills dfdy row-major (dfdy[i*n + j] = df_i/dy_j) and dfdt. */
typedef int (*tubes_gsl_rhs_fn)(double t, const double *y, double *dydt, void *user_data);
typedef int (*tubes_gsl_jac_fn)(double t, const double *y, double *dfdy, double *dfdt,
                                void *user_data);

typedef struct {
  gsl_odeiv2_system sys;   /* params points back to this struct */
  gsl_odeiv2_driver *d;    /* owns d->s (stepper), d->c (control), d->e (evolve) */
  tubes_gsl_rhs_fn rhs;
  tubes_gsl_jac_fn jac;
  void *user_data;         /* the Fortran callback context */
} tubes_gsl_work;

static pthread_once_t handler_once = PTHREAD_ONCE_INIT;

static void handler_off(void) { gsl_set_error_handler_off(); }

static int to_gsl(int s) { return s == 0 ? GSL_SUCCESS : (s > 0 ? GSL_FAILURE : GSL_EBADFUNC); }

static int sys_function(double t, const double y[], double dydt[], void *params) {
  tubes_gsl_work *w = (tubes_gsl_work *)params;
  return to_gsl(w->rhs(t, y, dydt, w->user_data));
}

static int sys_jacobian(double t, const double y[], double *dfdy, double dfdt[], void *params) {
  tubes_gsl_work *w = (tubes_gsl_work *)params;
  return to_gsl(w->jac(t, y, dfdy, dfdt, w->user_data));
}

/* kind 1: rk8pd, 2: rk4imp. Returns NULL on a bad kind or when GSL cannot allocate. */
void *tubes_gsl_shim_alloc(int kind, size_t n, tubes_gsl_rhs_fn rhs, tubes_gsl_jac_fn jac,
                           void *user_data, double atol, double rtol) {
  const gsl_odeiv2_step_type *type;
  tubes_gsl_work *w;
  pthread_once(&handler_once, handler_off);
  if (kind == 1)
    type = gsl_odeiv2_step_rk8pd;
  else if (kind == 2)
    type = gsl_odeiv2_step_rk4imp;
  else
    return NULL;
  if (n == 0 || rhs == NULL || jac == NULL || !(atol >= 0) || !(rtol >= 0)) return NULL;
  w = (tubes_gsl_work *)malloc(sizeof *w);
  if (w == NULL) return NULL;
  w->sys.function = sys_function;
  w->sys.jacobian = sys_jacobian;
  w->sys.dimension = n;
  w->sys.params = w;
  w->rhs = rhs;
  w->jac = jac;
  w->user_data = user_data;
  /* the driver's hstart (1.0) is never used: the Fortran side passes its own h to evolve */
  w->d = gsl_odeiv2_driver_alloc_y_new(&w->sys, type, 1.0, atol, rtol);
  if (w->d == NULL) {
    free(w);
    return NULL;
  }
  return w;
}

/* New tolerances for the y_new control (a_y = 1, a_dydt = 0); a fresh start of evolve and
 * stepper (counters to zero). Returns a GSL status. */
int tubes_gsl_shim_reset(void *vw, double atol, double rtol) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  int s = gsl_odeiv2_control_init(w->d->c, atol, rtol, 1.0, 0.0);
  if (s != GSL_SUCCESS) return s;
  return gsl_odeiv2_driver_reset(w->d);
}

int tubes_gsl_shim_set_tol(void *vw, double atol, double rtol) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  return gsl_odeiv2_control_init(w->d->c, atol, rtol, 1.0, 0.0);
}

/* One accepted step from *t towards t1 (never past it; *t = t1 exactly on the last one);
 * *h: proposed step in, proposed next step out. Returns a GSL status. */
int tubes_gsl_shim_apply(void *vw, double *t, double t1, double *h, double *y) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  return gsl_odeiv2_evolve_apply(w->d->e, w->d->c, w->d->s, &w->sys, t, t1, h, y);
}

/* f at the start and at the end of the last step (evolve's dydt_in and dydt_out). */
void tubes_gsl_shim_derivs(void *vw, double *f_start, double *f_end) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  size_t n = w->sys.dimension;
  memcpy(f_start, w->d->e->dydt_in, n * sizeof(double));
  memcpy(f_end, w->d->e->dydt_out, n * sizeof(double));
}

/* Accepted steps and failed attempts since the last reset. */
void tubes_gsl_shim_counts(void *vw, long *count, long *failed) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  *count = (long)w->d->e->count;
  *failed = (long)w->d->e->failed_steps;
}

/* GSL's text for a status code, NUL-terminated, truncated to len - 1 characters. */
void tubes_gsl_shim_strerror(int status, char *buf, int len) {
  if (len <= 0) return;
  strncpy(buf, gsl_strerror(status), (size_t)len - 1);
  buf[len - 1] = '\0';
}

void tubes_gsl_shim_free(void *vw) {
  tubes_gsl_work *w = (tubes_gsl_work *)vw;
  if (w == NULL) return;
  gsl_odeiv2_driver_free(w->d);
  free(w);
}
