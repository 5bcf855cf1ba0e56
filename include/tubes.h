/* tubes: the C view of the library's bind(C) API (src/capi/tubes_capi.f90); the driver's namelist
 * reader is include/tubes_input.h. Binding labels must differ from every Fortran module name (they
 * share one global namespace). Units: cm, s; energies per unit mass in (cm/s)^2. */
#ifndef TUBES_H
#define TUBES_H
#include <stdint.h>
#ifdef __cplusplus
extern "C" {
#endif

/* Status codes (src/base/tubes_status.f90, python/tubes/__init__.py). >= 0 success. */
enum {
  TUBES_OK = 0, TUBES_EVENT = 1,
  TUBES_FULL = 2, /* success, but before t_end: max_crossings crossings were recorded */
  TUBES_EINPUT = -1, TUBES_EMAXSTEPS = -2, TUBES_ESTEP = -3, TUBES_EMODEL = -4,
  TUBES_EIO = -5, TUBES_ENOCONV = -6,
  TUBES_EFAULT = -7, /* a failure injected by TUBES_FAULT (tests only) */
  TUBES_EOUTSIDE = -8, /* a tube crossed the section outside the region chosen on it */
  TUBES_ENOCROSS = -9, /* no crossing of the section within t_max */
  TUBES_EPASTEND = -10, /* past the end of the Lyapunov orbit family */
  TUBES_ENARROW = -11, /* the gate (&flux, &montecarlo) lies within twice the NHIM's reach along the reaction coordinate */
  TUBES_ENOJET = -12, /* no Taylor kernel for the model: its code could not be generated or compiled (stderr says why) */
  TUBES_EDIRECTION = -13, /* the tube crosses the section in the other direction first: choose the other direction */
  TUBES_EUNRESOLVED = -14, /* dE below what the energy resolves at the saddle (tubes_de_floor) */
  TUBES_ENOREGION = -15, /* the energy surface meets the plane section in no bounded region within its search window */
  TUBES_ESHAPE = -16, /* the transition region is not one star-shaped piece, or reaches the energy surface's edge */
  TUBES_EUNDECIDED = -17, /* a section point neither passed the gate nor returned within t_max */
  TUBES_EDISSIPATIVE = -18, /* a conservative-only computation asked of a dissipative model */
  TUBES_ENOISE = -19, /* a deterministic computation asked of a noisy model */
  TUBES_EINTERRUPT = -20 /* stopped by the caller: tubes_cancel_begin's SIGINT handler (Ctrl-C) */
};

/* Interrupting a call of the library (Python's Ctrl-C; src/base/tubes_cancel_shim.c): between
 * tubes_cancel_begin() and tubes_cancel_end(), SIGINT sets a flag instead of the caller's handler;
 * every ensemble (tubes_ensemble.f90) checks it before each unit of work and marks the items left
 * TUBES_EINTERRUPT, so the call returns within one unit. tubes_cancel_end() restores the caller's
 * handler and returns 1 if SIGINT came. Main thread only, not nested. */
/* Progress lines of the ensembles on stderr, at most once a second once a loop has run a second
 * (src/base/tubes_progress_shim.c): off until turned on (the program does; the library and Python
 * are silent). */
void tubes_progress_enable(int on);
/* A scene's progress line on stderr (every = 1: an item of its list, at most one a second). */
void tubes_progress_line(const char *text, int len, int every);

void tubes_cancel_begin(void);
int tubes_cancel_end(void);
int tubes_cancel_requested(void);
/* Sets the flag from the program's own signal handler (tubes_main.c: the first SIGINT or SIGTERM
 * during the scenes stops the run after the current unit and keeps the finished scenes). */
void tubes_cancel_request(void);

/* Integration methods (src/integrators/tubes_methods.f90). */
enum {
  TUBES_METHOD_DOP853 = 1, TUBES_METHOD_RK4 = 2, TUBES_METHOD_TAO2 = 3, TUBES_METHOD_TAO4 = 4,
  TUBES_METHOD_TAO6 = 5, TUBES_METHOD_GAUSS4 = 6, TUBES_METHOD_GAUSS6 = 7, TUBES_METHOD_GAUSS8 = 8,
  TUBES_METHOD_GSL_RK8PD = 9, TUBES_METHOD_GSL_RK4IMP = 10, TUBES_METHOD_CVODE_ADAMS = 11,
  TUBES_METHOD_ARKODE_ERK8 = 12, TUBES_METHOD_TAYLOR = 13,
  TUBES_METHOD_AUTO = 14 /* Taylor for a model's state, DOP853 for the variational equations and the action */
};
/* Method options (tubes_run_trajectory): omega_bind [1/s] for tao* (0 = default 200),
 * solver for gauss*: 0 or 1 simplified Newton, 2 fixed point; max_iter for gauss* (0 = default). */

/* A model is chosen by the name of its system (the library, docs/models.md) and its parameter
 * vector params[TUBES_MAXPARAM] in the order of tubes_model_info (the table in
 * src/models/tubes_models.f90 is the one definition). rolling_ball's order is {alpha [1/cm], beta [1],
 * gamma [cm^2], xi [1/cm], h0 [cm], g [cm/s^2], damping_ratio [1], rolling_resistance [1],
 * noise [(cm/s)^2/s], temperature [(cm/s)^2]}. */
enum { TUBES_NMODEL = 10, TUBES_LSYSTEM = 32, TUBES_MAXPARAM = 16, TUBES_LPARAM = 24,
       TUBES_MAXDOF = 3, TUBES_LUNITS = 16, TUBES_LDOC = 96, TUBES_LSUMMARY = 160 };

/* A run's stores for tubes_tube_cut, tubes_orbit_family, tubes_find_equilibria,
 * tubes_section_info, tubes_monte_carlo and tubes_poincare: a cut given one keeps its seeds there,
 * and a later cut of the same set-up (model, saddle, orbit options, energy, section, eps,
 * integration) looks up the seeds at the phases it shares with the earlier ones instead of
 * integrating them again (the same bits). Each orbit family (model, saddle, orbit options) is
 * continued once and each of its orbits found once, and each model's equilibria in a box found
 * once, for every call given the stores. For one caller at a time (the program's run); NULL:
 * none. */
void *tubes_seed_stores_new(void);
void tubes_seed_stores_free(void *stores);

/* The name of built-in system k = 0, 1, ... into name (NUL-terminated); TUBES_EINPUT past the
 * last one. */
int tubes_model_system(int k, char name[TUBES_LSYSTEM]);

/* The table entry of system `system` (NUL-terminated): degrees of freedom, np parameters with
 * names (blocks of TUBES_LPARAM chars), defaults, units (blocks of TUBES_LUNITS) and meanings
 * (blocks of TUBES_LDOC), a one-line summary; the scenes' defaults: the equilibrium search box
 * (half-widths and centre per coordinate), the saddle (by name, or "" and then by position
 * saddle_near), the section (kind "ray", "plane" or "" for none; plane: index 1..N, value,
 * direction; ray: angle [deg], direction = sign of p_theta) and the transit gate; surface: rolling_ball's surface formula ("" for
 * the others). Strings are
 * NUL-terminated within their blocks. TUBES_EINPUT for an unknown system. */
int tubes_model_info(const char system[TUBES_LSYSTEM], int *ndof, int *np, char names[],
                     double defaults[], char units[], char docs[], char summary[TUBES_LSUMMARY],
                     char length_units[8], double box[TUBES_MAXDOF],
                     double box_center[TUBES_MAXDOF], char saddle[8],
                     double saddle_near[TUBES_MAXDOF], char section_kind[8], int *section_index,
                     double *section_value, int *section_direction, double *section_angle,
                     double *gate, char surface[TUBES_LSUMMARY]);

/* Models written as formulas (src/io/tubes_expr.c, docs/models.md): a model whose system name
 * is expr_<16 hex digits> is the generated library of that name in the model cache. */
typedef void (*tubes_expr_fn)(const double *in, double *out);
typedef struct {
  int kind;      /* 1: a Hamiltonian H(q, p); 2: a rolling ball's surface h(x, y) */
  int ndof, natural;
  /* kind 1: energy, field (J grad H), gradient, hessian, then when natural: shape (V),
   * shape_derivs (grad V, Hess V), kinetic (A = d2H/dp2); kind 2: height, derivs (grad h, Hess h),
   * third (d3h). Matrices column by column. */
  tubes_expr_fn fn[7];
  int reversor[2 * TUBES_MAXDOF];     /* kind 1: signs of a reversor x -> r x of H, or zeros */
  char names[2 * TUBES_MAXDOF][16];   /* coordinates, then momenta (NUL-terminated) */
  char formula[TUBES_LSUMMARY];       /* the formula (truncated) */
} tubes_expr_lib_t;

/* Build or find in the cache the library of the model described by spec (the text written by
 * src/io/tubes_nml.f90); its name into key, its path into lib. On failure, the namelist variable
 * at fault into var ("hamiltonian", "height", "coordinates", "momenta", "constants" or "system")
 * and the reason into msg. seconds: time taken; hit: 1 if it came from the cache. */
int tubes_expr_build(const char *spec, char key[TUBES_LSYSTEM], char *var, int lvar, char *msg, int lmsg,
                     char *lib, int llib, double *seconds, int *hit);
/* The loaded library of name key (TUBES_EINPUT if it is not in the cache, or is refused: its
 * recorded SHA-256, owner or mode, docs/cluster.md "The model cache"; the reason on stderr). */
int tubes_expr_open(const char key[TUBES_LSYSTEM], tubes_expr_lib_t *lib);
/* For a signal handler (async-signal-safe: kill, unlink, rmdir): stop the code generator or
 * compiler running now (SIGKILL to its process group) and remove its build directory and lock
 * file. 1 if a tool was running. */
int tubes_expr_abort(void);
/* Can method = 'taylor' integrate the model (system, params) at relative tolerance eps? Its kernel
 * of that order is built or loaded now; TUBES_ENOJET and the reason in msg if not. */
int tubes_taylor_check(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], double eps, char *msg,
                       int lmsg);
/* The Taylor expansion of the Hamiltonian of the formula model key at z = (q, p) to total degree
 * order, from its formula (python/tubes/codegen.py --taylor: SymPy, exact coefficients rounded to
 * double): *n terms, *expo (2N exponents of (dq, dp) per term) and *coef, both malloc'ed. On
 * failure (a built-in model, no Python or SymPy) the reason in msg. */
int tubes_expr_taylor(const char key[TUBES_LSYSTEM], const double *z, int order, int *n, int **expo, double **coef,
                      char *msg, int lmsg);
/* The C compiler that builds models ($TUBES_CC, else the build's). */
const char *tubes_expr_compiler(void);
/* The spec text of the formula model key (its lines but the compiler's) into buf (len bytes). */
int tubes_expr_spec(const char key[TUBES_LSYSTEM], char *buf, int len);
/* A formula's constants as a scan's parameter (docs/scan.md): the value of constant `name` of the
 * formula model key (0; TUBES_EINPUT if it has none of that name; 1 if its value is a formula of
 * others, not a number); the names of those given as numbers, blank-separated, into buf (len
 * bytes); and the library of key's spec with that constant set to value (written as the shortest
 * decimal that reads back as it), built or loaded like any formula model: its name into newkey,
 * on failure the reason in msg (lmsg bytes). */
int tubes_expr_constant(const char key[TUBES_LSYSTEM], const char *name, double *value);
int tubes_expr_constant_names(const char key[TUBES_LSYSTEM], char *buf, int len);
int tubes_expr_with_constant(const char key[TUBES_LSYSTEM], const char *name, double value,
                             char newkey[TUBES_LSYSTEM], char *msg, int lmsg);

/* Taylor jets (src/io/tubes_expr.c, docs/integrators-taylor.md): the kernel computing the
 * normalised Taylor coefficients of the solution through a state, generated from a model's formula
 * (python/tubes/codegen.py --jet) and compiled for this processor, once (cached like a model).
 * Its call: fn(order, par, tc, w): par[0] the damping rate c (dp/dt -= c p); tc[(i*(order+1) + k)*L + l]
 * the coefficient k of component i in lane l, k = 0 given, 1..order computed; w scratch of
 * nwork*(order+1)*L doubles. Returns 0, or -1 where a coefficient is not finite. */
typedef int (*tubes_jet_fn)(int order, const double *par, double *tc, double *w);
/* flags of tubes_jet_get: the state transition matrix follows the state (column by column), the
 * action integral of p . dq/dt follows the state (after the state transition matrix, if any), one
 * tangent vector w with dw/dt = (df/dx) w follows the state (not with the matrix) */
enum { TUBES_JET_VARIATIONAL = 1, TUBES_JET_ACTION = 2, TUBES_JET_TANGENT = 4 };
/* The kernel of the model text `model` (the tubes-expression spec of a formula, or of a built-in
 * written as one) for order 1..60 and L = lanes (1, 2, 4, 8) (straight-line code for that order);
 * with flags (an extended state), order 0 and lanes 1: a kernel of any order (loops: much quicker
 * to compile). dim: the state's dimension. Thread-safe; the first call for a kernel builds or
 * loads it (and says so on stderr when it builds). */
int tubes_jet_get(const char *model, int order, int lanes, int flags, tubes_jet_fn *fn, int *dim, int *nwork,
                  char *msg, int lmsg);
/* The lanes' width (integrations per kernel call) of ensembles on this processor: $TUBES_LANES if
 * set (1, 2, 4 or 8), else 8 with AVX-512F, 4 with AVX, 2 otherwise. Returns the width, or
 * TUBES_EINPUT with the reason in msg (an invalid TUBES_LANES). */
int tubes_jet_lanes_default(char *msg, int lmsg);
/* The lanes' driver's build to run (src/integrators/tubes_lanes_run.f90, compiled once per
 * instruction set): 0 the build for any processor of the architecture, 1 x86-64-v3 (AVX2), 2
 * x86-64-v4 (AVX-512). forced >= 0: that one; else $TUBES_LANES_DRIVER if set (x86-64, x86-64-v3
 * or x86-64-v4); else the widest this processor runs. TUBES_EINPUT with the reason in msg for a
 * build this processor cannot run or an unknown name. */
int tubes_lanes_driver(int forced, char *msg, int lmsg);
/* The name of the lanes' driver's build d (0, 1, 2: "x86-64" (or the architecture's on another
 * processor), "x86-64-v3", "x86-64-v4"). */
const char *tubes_lanes_driver_name(int d);

/* Copy the text of status `code` into buf (NUL-terminated, at most len bytes; TUBES_LSTATUS holds
 * every message whole). */
enum { TUBES_LSTATUS = 320 };
void tubes_status_message(int code, char *buf, int len);

/* *natural = 1 if the model is natural (H = 1/2 p^T A(q) p + V(q): rest points, brake orbits). */
int tubes_model_natural(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                        int *natural);

/* The Monte Carlo check's verdict (docs/tubes.md, "Monte Carlo check"): of n points, n_transit
 * transited, n_undecided undecided and misclassified against the tube's inside; p the tube's
 * p_trans. *sigmas: the count's distance from p in standard errors of a binomial count with p;
 * *sigma_limit: the most it may be; *mis_lim, *und_lim: the most misclassified and undecided
 * points; *agrees: 1 if all three hold. */
void tubes_mc_agreement(int n, int n_transit, int n_undecided, int misclassified, double p, double *sigmas,
                        double *sigma_limit, int *mis_lim, int *und_lim, int *agrees);

/* *quadratic = 1 if H is quadratic in the momenta on the plane q_index = value (index 1 or 2) of a
 * 2-DOF model, over the range of the other coordinate a plane section searches (the box lo, hi
 * widened by half its width on each side): the plane section's premise (docs/tubes.md). */
int tubes_plane_quadratic(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                          const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int index, double value,
                          int *quadratic);

/* The smallest |dE| the energy resolves at a saddle of energy e_saddle: E_e + dE is known to about
 * 16 ulps of |E_e|, and dE to 1e-6 of itself from 1e6 times that on. The calls that take a smaller
 * dE return TUBES_EUNRESOLVED. */
double tubes_de_floor(double e_saddle);

/* Energy H(x) of the state x[n] (n = 2 N) on the conservative model. */
int tubes_energy(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], int n,
                 const double x[], double *energy);

/* Hamilton's equations dx/dt at the state x[n] (damped for the rolling ball with
 * damping_ratio > 0). */
int tubes_vector_field(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                       int n, const double x[], double dxdt[]);

/* rolling_ball only: momenta p = (7/5) M v of a ball at position q with planar velocity v. */
int tubes_momentum(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                   const double q[2], const double v[2], double p[2]);

/* Damping rate [1/s] of the field the scenes integrate (rolling_ball: c = 2 zeta omega_1 for
 * damping_ratio = zeta; 0 for conservative models). */
int tubes_damping_rate(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                       double *c);

/* The method a run integrates with (src/workflow/tubes_setup.f90 method_resolved): code itself; for
 * 'taylor' and 'auto' without the model's Taylor kernel at tolerance eps, DOP853 ('auto') or 0
 * ('taylor': refused), the reason in why (NUL-terminated, lwhy bytes). */
int tubes_method_resolved(int code, const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], double eps,
                          char *why, int lwhy);

/* The run's saddle (src/workflow/tubes_setup.f90 run_saddle): the equilibria in the box [lo, hi] (kept
 * in stores), then the one by name, or (use_near) the nearest to near, that the scenes take
 * (degenerate_ok: a degenerate one too); label the model's name in messages, dflt: name is the
 * system's default. Returns 0 (chosen, e_saddle: its name and energy), a refusal's code > 0, or the
 * equilibria search's status < 0; msg says why (len bytes). */
int tubes_run_saddle(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], const double lo[TUBES_MAXDOF],
                     const double hi[TUBES_MAXDOF], int n_grid, void *stores, const char name[8], int use_near,
                     const double near[TUBES_MAXDOF], int degenerate_ok, const char *label, int dflt, char chosen[8],
                     double *e_saddle, char *msg, int len);

/* The dissipation of the field the scenes integrate (docs/dissipation.md): *c the viscous rate
 * [1/s] (damping_ratio), *f the rolling drag C_rr g [cm/s^2] (rolling_resistance); 0 for none. */
int tubes_dissipation(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], double *c,
                      double *f);

/* Equilibria of Hamilton's equations with q in the box lo[k] <= q_k <= hi[k] (k < ndof) from an
 * n_grid^ndof Newton grid; *n of them (at most nmax, else TUBES_EINPUT), *ndof = N. Per point k
 * (blocks of TUBES_MAXDOF): q, p; height (natural systems: the potential's shape, the ball's
 * H(x, y) [cm]; others: the energy), energy, grad_norm (Newton residual), morse (index: the
 * eigenvalues of the linearised flow with positive real part), rank1 (1: saddle x centre^(N-1); 2: a degenerate saddle, one real pair and the rest centres or 0),
 * names (blocks of 8 chars). For rank-1 saddles: lambda [1/time], omega (blocks of
 * TUBES_MAXDOF - 1, ascending) and evec (blocks of 4 TUBES_MAXDOF^2; the first (2N)^2 hold the
 * 2N x 2N matrix of columns u, s, Re c_1, Im c_1, ..., column-major, each column of unit length:
 * Re c_k and Im c_k normalised separately span the k-th centre plane, and Re + i r Im is the
 * eigenvector for r = |Im c_k|/|Re c_k|, not r = 1; docs/output.md, /saddle); zero for the others.
 * With stores (tubes_seed_stores_new, or NULL), a run's later calls for the same model, box and
 * grid take the equilibria an earlier call found (the tube-dynamics calls below too). */
int tubes_find_equilibria(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                          const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                          int nmax, int *n, int *ndof, double q[], double p[], double height[],
                          double energy[], double grad_norm[], int morse[], int rank1[],
                          char names[], double lambda[], double omega[], double evec[], void *stores);
/* The centre frequencies of every equilibrium found by tubes_find_equilibria with the same
 * arguments, in its order: freqs[TUBES_MAXDOF * k + i] the k-th's i-th, ascending (NaN where fewer
 * than N pairs are centres), stable[k] 1 when all N pairs are centres (linearly stable). */
int tubes_equilibria_centres(const char *system, const double *params, const double *lo, const double *hi, int n_grid,
                             int nmax, int *n, double freqs[], int stable[], void *stores);
/* What the equilibrium search box may hide (docs/models.md "The search box"): an equilibrium on a
 * face of [lo, hi], or a natural model without a well in the box whose potential on the faces is
 * lower than at every equilibrium found. note: one line, or "" when nothing (lnote bytes). */
int tubes_box_note(const char *system, const double *params, const double *lo, const double *hi, int n_grid,
                   char *note, int lnote, void *stores);

/* Scenes and their records (docs/development.md, "Scenes and their records"): a scene of the
 * core (src/workflow/tubes_scene_*.f90) returns a record's handle; its items are datasets and
 * attributes (kind TUBES_REC_*, a group path, a name, units, a rank and C-order dims), its lines
 * the console's (stream 1 stdout, 2 stderr), its code the worst verdict's exit code. The C driver
 * walks it (src/io/tubes_record_write.c); tubes_record_free forgets it. */
enum { TUBES_REC_REAL = 1, TUBES_REC_INT = 2, TUBES_REC_STRINGS = 3, TUBES_REC_ATTR_REAL = 4, TUBES_REC_ATTR_INT = 5,
       TUBES_REC_ATTR_STRING = 6 };
int tubes_record_code(int h);
void tubes_record_sizes(int h, int *n_items, int *n_lines);
int tubes_record_line(int h, int j, int *stream, char *buf, int len);
int tubes_record_item(int h, int k, int *kind, char group[256], char name[64], char units[32], int *rank,
                      long long dims[5], int *slen);
void tubes_record_reals(int h, int k, int n, double *v);
void tubes_record_ints(int h, int k, int n, int *v);
long long tubes_record_long(int h, int k);
void tubes_record_string(int h, int k, int j, char *buf, int len);
void tubes_record_free(int h);

/* Progress callback: called every few thousand steps with the current time; return
 * non-zero to stop the integration (the result so far is returned with TUBES_OK). */
typedef int (*tubes_progress_fn)(double t, void *user);

/* Integrate from x0 at t = 0 to t_end, sampling every dt_out (nmax >= floor(t_end/dt_out)+2),
 * and record every crossing of a section: sec_kind 0 none, 1 the ray theta = sec_level [rad]
 * (sec_dir = sign of p_theta wanted, 0 both; U1^- is sec_level = pi/4, sec_dir = +1), 2 the line
 * x = sec_level [cm], 3 y = sec_level (sec_dir = sign of dx/dt or dy/dt, 0 both); stop_first != 0
 * stops at the first crossing; at most max_cross are recorded (then the run stops).
 * Outputs: *n samples t[n], state[4 n] (row k = x, y, px, py), energy[n]; *n_cross crossings
 * cross_t, cross_x[4 n_cross], cross_dir (+1/-1); counters = {nfev, nsteps, nrejected, niter};
 * *c_damp = damping rate used [1/s]. On failure the samples and crossings up to the last
 * accepted step are returned with a status < 0. */
int tubes_run_trajectory(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                         int n2, const double x0[], double t_end,
                         double dt_out, int method, double rtol, double atol, double h,
                         int64_t max_steps, double omega_bind, int solver, int max_iter,
                         int sec_kind, double sec_level, int sec_dir, int stop_first, int max_cross,
                         int nmax, int *n, double t[], double state[], double energy[],
                         int *n_cross, double cross_t[], double cross_x[], int cross_dir[],
                         int64_t counters[4], double *c_damp, tubes_progress_fn progress,
                         void *user);

/* The orbit, tube, Monte Carlo and Poincare calls integrate with `method` (a TUBES_METHOD_*
 * code) and its options as tubes_run_trajectory (h: the fixed step of fixed-step methods,
 * omega_bind, solver, max_iter / int_max_iter); their tolerances are their own arguments.
 * Lyapunov orbits of the rank-1 saddle named `saddle` ("S12", ...) at the ascending excess
 * energies des[nde] [(cm/s)^2], by continuation from dE -> 0 (docs/orbits.md). n_segments 1 =
 * single shooting of the brake orbit, >= 2 = multiple shooting. Per orbit k (arrays of nde
 * blocks): energy, period [s], action [cm^2/s], state0[4], mu_u, mu_s, mu_triv[4] (Re, Im of the
 * trivial pair), stab (stability index), residual (corrector), closure (|x(T) - x(0)|),
 * iterations, converged (1/0), mindist (closest approach to another equilibrium, cm),
 * monodromy[16] (column-major 4x4), ts[nsamp] and xs[4 nsamp] samples over one period,
 * history[max_iter] (residual after each Newton iteration). *end_de: the estimated end of the
 * family (-1 if none was met); *end_reason: 0 none, 1 another equilibrium, 2 period without
 * bound, 3 correction fails. Orbits past the end have converged = 0. Each orbit is the
 * continuation to its own energy alone, whatever else des holds; with stores (or NULL), a run's
 * later calls of the same family take the continuation and the orbits found by earlier ones (and
 * by tubes_tube_cut's: docs/orbits.md, "One family, each orbit once"). local = 1: computed on
 * this MPI rank alone (a caller that has dealt out its work), else by all ranks together.
 * nguess > 0: the family through the state guess[nguess] (nguess = 2N) of period guess_period,
 * corrected by multiple shooting (n_segments segments) at its own energy and continued by
 * pseudo-arclength (des of any sign; docs/orbits.md, "Orbits from a guess"); *end_reason then also
 * 6 the arc's step limit, 7 back past the start after a fold, 8 the guess did not converge, 9 no
 * requested energy on the branch's side. family <= -101: the family branching off at the
 * (-100 - family)-th bifurcation of the guess's family (tubes_orbit_bifurcations; without a guess,
 * of family 1). */
int tubes_orbit_family(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                       const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                       const char saddle[8], int nde,
                       const double des[], int n_segments, int family, double tol, double rtol, double atol,
                       int max_iter, int nsamp, int method, double h, double omega_bind, int solver,
                       int int_max_iter, double energy[], double period[], double action[],
                       double state0[], double mu_u[], double mu_s[], double mu_triv[],
                       double stab[], double residual[], double closure[], int iterations[],
                       int converged[], double mindist[], double monodromy[], double ts[],
                       double xs[], double history[], double *end_de, int *end_reason, int local,
                       void *stores, int nguess, const double guess[], double guess_period);

/* The orbits asked for by a parameter other than dE (docs/orbits.md, "Orbits by Jacobi constant or
 * period"; src/workflow/tubes_orbit_parameter.f90): the excess energies des[k] of the family's (the
 * arguments of tubes_orbit_family up to int_max_iter, then local, stores and the guess) orbits at
 * values[k], n of them, of kind 1 (the Jacobi constant: dE = E(C) - E_e, the model's definition) or 2
 * (the period: the first crossing of T(dE) = T from the saddle, located by GSL's Brent to |T - T*| <=
 * 1e-12 T*; the Lyapunov families 1 .. N-1 only, else TUBES_EINPUT). found[k]: 0 found, 1 the family
 * does not reach it, 2 the root finder or the orbit there failed, 3 the model has no Jacobi constant;
 * t_po the saddle's limit 2 pi / omega, t_reach and de_reach the last period (and its dE) the search
 * reached, e_saddle E_e. */
int tubes_orbit_by_parameter(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                             const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                             const char saddle[8], int kind, int n, const double values[], int n_segments, int family,
                             double tol, double rtol, double atol, int max_iter, int nsamp, int method, double h,
                             double omega_bind, int solver, int int_max_iter, int local, void *stores, int nguess,
                             const double guess[], double guess_period, double des[], int found[], double *t_po,
                             double *t_reach, double *de_reach, double *e_saddle);

/* The Jacobi constants c[k] at the energies energy[k] of a model that defines one (C = -2 H for the
 * CR3BP; src/models/tubes_cr3bp.f90): TUBES_EINPUT (c = 0) for a model without one. */
int tubes_jacobi_constant(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], int n,
                          const double energy[], double c[]);

/* Bifurcation monitoring of the family of tubes_orbit_family (the same arguments up to
 * int_max_iter; docs/orbits.md, "Bifurcations"). nu[4 nde]: per orbit k the Floquet indices
 * (lambda + 1/lambda)/2 of its N - 1 nontrivial multiplier pairs, Re in nu[4k + 0 .. N-2], Im in
 * nu[4k + 2 .. 2 + N-2] (descending real part; 0 where not converged). Between consecutive converged
 * orbits, each change in the count of real indices above +1 (kind 1, a branch point or fold), below
 * -1 (kind 2, period doubling) or of complex ones (kind 3, a Krein collision) is located by bisection
 * in dE to a bracket <= *bif_tol dE (1e-11). *nbif: how many were found (the first max_bif are returned); per
 * bifurcation j: kind, after (0-based: between orbits after and after + 1), bde (dE, the bracket's
 * midpoint), bwidth (the bracket), benergy, bperiod, bnu[4j ..] (the indices there, as nu),
 * bconv (1: the orbit at bde converged; 0: the corrector failed inside the bracket, which stopped),
 * bx0[6j ..] that orbit's start (state0) and btan[6j ..] the monodromy's eigenvector there for the
 * multiplier +1 (kind 1, orthogonal to the flow) or -1 (kind 2): the new family's tangent (0 for kind 3).
 * Along a guess's family also kind 4, a fold (the energy along the family turns back; found by the
 * continuation, located by bisection in arclength): after = the number of requested energies below it
 * minus 1, bwidth the bracket in arclength, btan the family's tangent there. Not along branch families. */
int tubes_orbit_bifurcations(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                             const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                             const char saddle[8], int nde, const double des[], int n_segments, int family,
                             double tol, double rtol, double atol, int max_iter, int nsamp, int method, double h,
                             double omega_bind, int solver, int int_max_iter, double nu[], int max_bif, int *nbif,
                             int kind[], int after[], double bde[], double bwidth[], double benergy[],
                             double bperiod[], double bnu[], int bconv[], double bx0[], double btan[], double *bif_tol, int local,
                             void *stores, int nguess, const double guess[], double guess_period);

/* Continuation in a model parameter (docs/scan.md; src/workflow/tubes_scan.f90): parameter ipar
 * (1-based, the table's order; tubes_scan_parameter) moves from params[ipar - 1] to `to` in n equal
 * steps. Per step j (0 .. n): value[j]; the equilibria (n_eq[j], at most TUBES_SCAN_MAXEQ; continued by
 * Newton from step j - 1's, researched[j] = 1 where they were searched anew after a fold):
 * eq_q[3 (TUBES_SCAN_MAXEQ j + k) ..], eq_energy[TUBES_SCAN_MAXEQ j + k], eq_index (the index),
 * eq_det (the sign of the Jacobian's determinant), eq_name[8 (TUBES_SCAN_MAXEQ j + k) ..] (ASCII codes,
 * blank-padded); the saddle (saddle_found[j]): saddle_q[3 j ..], saddle_energy, lambda, omega[2 j ..];
 * its orbits at des[nde] (nde may be 0): period, action, stability, converged, restarted [max(nde, 1)
 * j + i] (restarted 1: continued in energy from the saddle, not corrected from step j - 1's orbit).
 * Folds (n_fold found, the first max_fold recorded): fold_step (between steps fold_step - 1 and
 * fold_step, 1-based), fold_value, fold_width (the bisection's bracket), fold_kind (1: two equilibria
 * meet and disappear; 2: the determinant changes sign), fold_q[3 i ..], fold_name[8 i ..] and
 * fold_partner[8 i ..] (names as eq_name); fold_tol: the bracket's width over |to - start|.
 * NaN (reals), -1 (eq_index) or 0 where there is nothing. TUBES_EINPUT for bad arguments (ipar, n < 1,
 * to equal to the start, a model refused at a step's value, more than TUBES_SCAN_MAXEQ equilibria).
 * p_trans_on != 0 (docs/scan.md, "p_trans along the scan"): at each step with the saddle and each dE,
 * the transition scene's p_trans = A_tube/A_E at the step's parameters (the cut on the section
 * sec_kind, sec_index, level, dir with the stable tube's eps, area_tol, t_max, n_init, n_max, as
 * tubes_tube_cut; A_E as tubes_section_info): a_tube, a_e, p_trans, p_status [max(nde, 1) j + i]
 * (p_status: the cut's status, else the energy surface's; TUBES_EINPUT where the step has no saddle;
 * NaN where either failed). p_trans_on == 0: those four are not touched (may be NULL). */
enum { TUBES_SCAN_MAXEQ = 64 };
int tubes_parameter_scan(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
               const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid, const char saddle[8],
                         int ipar, double to, int n, int nde, const double des[], int n_segments, double tol, double rtol,
               double atol, int max_iter, int nsamp, int method, double h, double omega_bind, int solver,
               int int_max_iter, double value[], int n_eq[], int researched[], double eq_q[], double eq_energy[],
               int eq_index[], int eq_name[], int eq_det[], int saddle_found[], double saddle_q[],
               double saddle_energy[], double lambda[], double omega[], double period[], double action[],
               double stability[], int converged[], int restarted[], int max_fold, int *n_fold, int fold_step[],
               double fold_value[], double fold_width[], int fold_kind[], double fold_q[], int fold_name[],
               int fold_partner[], double *fold_tol, int p_trans_on, int sec_kind, int sec_index, double level,
               int dir, double eps, double area_tol, double t_max, int n_init, int n_max, double a_tube[],
               double a_e[], double p_trans[], int p_status[]);
/* The index (1-based) of the parameter `name` of system that a scan takes, 0 if none (a dissipation
 * parameter, a formula's constant defined by a formula of others, an unknown name); a formula's
 * constant given as a number is TUBES_SCAN_CONSTANT + k (the k-th of them); allowed[len]: those it
 * takes, blank-separated. */
int tubes_scan_parameter(const char system[TUBES_LSYSTEM], const char name[TUBES_LPARAM], char *allowed, int len);
/* The start value of the scan's parameter ipar (tubes_scan_parameter's index; a formula's constant:
 * above TUBES_SCAN_CONSTANT) of system with params: params[ipar - 1] or the constant's value. */
enum { TUBES_SCAN_CONSTANT = 1000 };
int tubes_scan_start(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM], int ipar, double *start);

/* Sections of the tube-dynamics calls (docs/tubes.md, "Sections"): sec_kind 1 = the rolling
 * ball's ray theta = level [rad], dir = sign of p_theta, coordinates (r, p_r); sec_kind 2 = the
 * plane q_{sec_index} = level (sec_index 1..N), dir = sign of dq/dt at the crossing,
 * coordinates (s, p_s) = (q_j, p_j) of the other degree of freedom. TUBES_EINPUT for a section
 * that makes no sense for the model (a ray on another model, an index out of range) or that the
 * energy surface does not meet.
 * The energy surface on the section at E = E_e(saddle) + de: its interval [rmin, rmax] of s,
 * area A_E and dA_E/dE (docs/tubes.md). */
int tubes_section_info(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                       const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                       const char saddle[8], int sec_kind, int sec_index, double level,
                       int dir, double de, double *rmin, double *rmax, double *area,
                       double *darea, void *stores);

/* The leading order of p_trans at small de: (tpo/a0) de (1 - tau de/a0), tpo = 2 pi/omega of the
 * saddle, a0 and tau = dA_E/dE the energy surface's area and its derivative on the section at the
 * saddle's energy (tubes_section_info at de = 0). */
double tubes_p_trans_leading(double tpo, double a0, double tau, double de);

/* The flux scene's verdicts (src/workflow/tubes_verdicts.f90, which the scene itself calls:
 * src/workflow/tubes_scene_flux.f90), for the library's C callers:
 * 0 where the check holds, 2 (the exit code) where it fails, its message then in msg (len bytes). */
int tubes_verdict_flux_too_small(double de, int ndof, double lead, char *msg, int len);
int tubes_verdict_flux_undecided(double de, const int counts[4], double gate, double t_max, char *msg, int len);
int tubes_verdict_flux_normal_form(double de, int order, double nf, double change, double fl, double fe, double *z,
                                   char *msg, int len);
int tubes_verdict_section(double de, double nf, double nfc, double fl, double fe, double sv, double sve, double sf,
                          double sfe, int ns, const double *w, const int counts[4], double t_max, int *use_nf,
                          double *p_theory, double *z, char *msg, int len);
int tubes_verdict_cut3(double de, double vol, double vol_half, double vol_x, double f, double sv, int n_decided,
                       int n_misclassified, char *msg, int len);
/* an orbit's closure over mu_unstable against its state's size (scale): 2 and the message where the
 * integration is too coarse for the orbit */
int tubes_verdict_orbit_coarse(double de, double closure, double mu, double scale, char *msg, int len);
/* the Monte Carlo check (the rule tubes_mc_agreement's): 2 and the message where it fails; *agrees 0/1 */
int tubes_verdict_montecarlo(double de, int n, int n_transit, int n_undecided, int misclassified, double p, int noisy,
                             const char saddle[8], double *sigmas, int *agrees, char *msg, int len);

/* Whether a scene applies to a model of ndof degrees of freedom (plane: a plane section, not the ray):
 * 0, or 1 (not with this many degrees of freedom) / 2 (a 3-DOF tubes scene needs a plane) with the
 * message's body (src/workflow/tubes_setup.f90 scene_refused, which Python's calls use too). */
int tubes_scene_refused(const char *scene, int ndof, int plane, const char *label, char *msg, int len);

/* The cut of the stable (kind -1) or unstable (kind +1) tube of the saddle's periodic orbit of
 * family `family` (as &orbits family: 1 .. N-1, -1 halo_north, -2 halo_south) at
 * excess energy de with the section (as tubes_section_info; N > 2: a plane q_index = level for its
 * crossings alone, r and pr its first pair (q_j, p_j), j != index), refined until
 * the area changes by < area_tol (relative) or n_max (<= nout) seeds. Outputs: *n points tau, r,
 * pr (the section's s, p_s), time (flight time to the section, signed), xs[2N n] (room for
 * 2 TUBES_MAXDOF nout); *area (Green's theorem on periodic splines; N > 2 the loop integral of
 * p . dq, the sum over the pairs), *area_polygon, the orbit's *action and *period, and the refinement history
 * hist_n[64], hist_area[64] (*nhist rounds). Orbit options as &orbits. When seeds fail (no
 * crossing within t_max, an integration failure), *n_failed counts them and *fail_tau is the
 * orbit phase [s] of the first. floquet[2N]: the unit eigenvector of the orbit's monodromy for
 * the manifold's multiplier at its x0, *sigma the branch (+-1): the seed at phase tau is
 * x(tau) + sigma eps v(tau)/|v_q(tau)|, v(tau) = Phi(tau) floquet. local = 0: the seeds (and multiple-shooting segments) are
 * shared among all MPI ranks, which must all call; local = 1: this rank computes the cut alone
 * (the caller deals out whole cuts, e.g. energies, to ranks). TUBES_EOUTSIDE: the tube crosses
 * the plane outside the region chosen on it (first on another part of the line). */
int tubes_tube_cut(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                   const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                   const char saddle[8], double de, int kind, int sec_kind, int sec_index,
                   double level, int dir, double eps, double area_tol, double t_max,
                   int n_init, int n_max, int n_segments, int family, double orb_tol, double orb_rtol,
                   double orb_atol, int method, double h, double omega_bind, int solver,
                   int max_iter, int nout, int *n, double tau[], double r[], double pr[],
                   double time[], double xs[], double *area, double *area_polygon,
                   double *action, double *period, int *nhist, int hist_n[64],
                   double hist_area[64], int *n_failed, double *fail_tau,
                   double floquet[2 * TUBES_MAXDOF], double *sigma, int local, void *stores);

/* Monte Carlo check at de: nsamp points uniform on the section's energy surface (GSL MT19937,
 * seed), each integrated until it returns to the section (outcome 0), passes the saddle's gate,
 * the hyperplane gate past the saddle across its neck (for a natural model the configuration part
 * of its unstable eigenvector; docs/input.md) away from the section's well (outcome 1: transit) or t_max (2); a sample whose integration failed has its (negative)
 * status as outcome. inside[k] = 1 if (r, pr) lies inside the cut (cut_r, cut_pr). */
int tubes_monte_carlo(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                      const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                      const char saddle[8], double de, int sec_kind, int sec_index,
                      double level, int dir, int nsamp, int seed, double t_max, double gate,
                      int method, double h, double omega_bind, int solver, int max_iter, int ncut, const double cut_r[], const double cut_pr[], double r[],
                      double pr[], int outcome[], int inside[], void *stores);

/* The eigenvalues wr[k] + i wi[k] (k < 2N, ascending real part) of the named saddle linearised with
 * the model's dissipation (&model damping_ratio), *c its damping rate (0: the conservative spectrum). */
int tubes_saddle_spectrum(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                          const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                          const char saddle[8], double wr[2 * TUBES_MAXDOF], double wi[2 * TUBES_MAXDOF], double *c,
                          void *stores);

/* The transition region at de (docs/dissipation.md): the points of the section's energy surface
 * whose trajectory under the model with its dissipation (&model damping_ratio) passes the saddle's
 * gate (a distance gate past it, as tubes_monte_carlo's) before it meets the section again, each
 * integrated to at most t_max. Its boundary is traced along rays from a point inside (found on a
 * scan of the section, which also checks the traced region), the rays doubled until the area
 * changes by at most area_tol (relative); the other options are src/transport/tubes_region.f90's
 * (region_opts_t). Out: the *n <= nout rays: phi[] (angle in the scaled coordinates), rho[]
 * (radius), s[], p[] (the boundary point), t_in[] (flight time of the last transiting point of
 * the ray's bisection: it lingers at the saddle); the boundary interpolated at *m = mcurve angles
 * cs[], cp[] (0 when empty); res[12] = {area, area_polygon, centre s, p_s, scale s, p_s, damping
 * rate c [1/time], A_E, de_lo, de_hi, area_hi, area_change}; counts[8] = {scan points, their
 * transits, undecided, points the traced region puts on the wrong side, points integrated,
 * rounds, empty (1: no transit), the failed ray's status}. An empty region (counts[6] = 1) has
 * its threshold: no transit at or below de_lo, a region of area area_hi at de_hi (de_hi - de_lo
 * <= 1e-6 de_hi; de_hi NaN: none found up to de_lo). TUBES_ESHAPE: not one star-shaped piece (or
 * the scan disagrees); TUBES_EUNDECIDED: a point neither transited nor returned within t_max;
 * TUBES_ENOCONV: not converged within min(nout, its n_max) rays; TUBES_ENARROW: gate within twice
 * the NHIM's reach; TUBES_ENOISE for a model with noise unless noiseless = 1 (then the region of
 * the model without its noise: the Monte Carlo check's D -> 0 limit). local as tubes_tube_cut. */
int tubes_transition_region(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                            const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                            const char saddle[8], double de, int sec_kind, int sec_index, double level, int dir,
                            double gate, double t_max, double area_tol, int method, double h, double omega_bind,
                            int solver, int max_iter, int nout, int mcurve, int *n, double phi[], double rho[],
                            double s[], double p[], double t_in[], int *m, double cs[], double cp[],
                            double res[12], int counts[8], int local, int noiseless, void *stores);

/* The reach at de of the saddle's NHIM (its Lyapunov orbits) across the saddle's neck, from the
 * linearisation [units of q]: tubes_monte_carlo refuses a gate within twice it (TUBES_ENARROW). */
int tubes_gate_reach(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                     const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                     const char saddle[8], double de, double *reach, void *stores);

/* The flux of trajectories through the saddle's bottleneck at de (src/transport/tubes_flux.f90, natural
 * systems; docs/theory.md): sampled on the dividing surface with nsamp points from seed (flux,
 * its standard error err), each followed to t_max at tolerance tol out of the slab of half-width
 * gate; leading = (2 pi)^(N-1) de^(N-1) / ((N-1)! prod omega_k); counts = {points inside the
 * energy shell, reacting, recrossing the other way, undecided}; box[2 (N-1)] the sampling box
 * of the dividing surface's coordinates. TUBES_EINPUT for a model that is not natural. */
int tubes_flux_sample(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                      const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid, const char saddle[8],
               double de, int nsamp, int seed, double t_max, double gate, double tol, int method, double h,
               double omega_bind, int solver, int max_iter, double *flux, double *err, double *leading,
               int counts[4], double box[2 * (TUBES_MAXDOF - 1)]);

/* The energy surface's volume on the plane section q_k = c (k = 1..N, crossed with sign(dq_k/dt)
 * = dir) at de above the saddle, sampled like the flux (natural systems), and the fraction of it
 * that passes the saddle's slab (half-width gate) on the far side before returning to the section:
 * the transition fraction, which tube dynamics predicts as flux / volume (src/transport/tubes_flux.f90;
 * docs/theory.md). counts = {inside the shell, transits, returns, undecided}. TUBES_EOUTSIDE if the
 * section's point nearest the saddle lies outside the energy shell. */
int tubes_section_transit(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                          const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid, const char saddle[8],
                          double de, int k, double c, int dir, int nsamp, int seed, double t_max, double gate,
                          double tol, int method, double h, double omega_bind, int solver, int max_iter,
                          double *volume, double *volume_err, double *fraction, double *fraction_err, int counts[4],
                          double x[], double w[], int cls[]);
/* ... and every sample: x[6 i + j] its state (j < 2N; NaN outside the shell), w[i] its weight
 * (the momenta's ellipsoid volume), cls[i] = 1 transit, -1 return, 2 undecided, 3 outside. */

/* The cut of the stable tube of a 3-DOF saddle's NHIM at de with the plane q_k = c (crossed with
 * sign(dq_k/dt) = dir; src/orbits/tubes_cut3.f90, docs/theory.md "Tube cuts in 3 DOF"): the normal form of
 * degree order from the Taylor expansion (n_terms terms: expo[6 t + i], coef[t]) at the saddle's
 * state zs; seeds on n_cut + 1 rings of (2 n_cut)^2 NHIM points, stepped off by eps times the
 * NHIM's radius, followed backwards to their first crossing. Out: xcut[6 m + j] the state of node m
 * at the section, tcut[m] its time (< 0), stcut[m] its status (0, 1 no crossing within t_max,
 * 2 crossed the other way first, < 0 a failure). The section's Monte Carlo points pts[6 i + j]
 * (NaN: none) with weights w[i] and classes cls[i] (tubes_section_transit's) are placed:
 * inside[i] = 1 inside the cut, 0 outside, -1 not a point: the parity of the crossings of its line
 * along q_a, those near it moved onto the smooth (tricubic) interpolant of the nodes by Newton;
 * inside_pl[i] the same on the piecewise-linear cut. diag[TUBES_CUT3_NDIAG]: the seeds' largest
 * |H - E| / dE before their correction, the cut's 4-volume V, failed nodes, V_h on every other node,
 * V_x = V + (V - V_h) / 3, unresolved points (Newton failed: the linear crossing kept), decided
 * points misclassified, the same by the linear cut, decided points, points inside, the weighted
 * fraction inside (p_trans of the tube), the weighted fraction that transits. TUBES_ENOCROSS if a
 * node failed; TUBES_EINPUT with msg for a refused normal form or plane. */
#define TUBES_CUT3_NODES(n_cut) (((n_cut) + 1) * 4 * (n_cut) * (n_cut))
#define TUBES_CUT3_NDIAG 12
int tubes_tube_cut3(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                    const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid, const char saddle[8],
                    int order, int n_terms, const int expo[], const double coef[], const double zs[6], double de,
                    int k, double c, int dir, int n_cut, double eps, double t_max, double tol, int method, double h,
                    double omega_bind, int solver, int max_iter, int n_pts, const double pts[], const double w[],
                    const int cls[], int inside[], int inside_pl[], double xcut[], double tcut[], int stcut[],
                    double diag[TUBES_CUT3_NDIAG], char *msg, int lmsg);

/* The Birkhoff normal form of H from its Taylor coefficients at a saddle x centre^(N-1)
 * equilibrium (src/orbits/tubes_normal_form.f90; docs/theory.md): n_terms terms, expo[t 2N + i] the
 * exponent of the i-th of (dq_1..dq_N, dp_1..dp_N) in term t, coef[t]; to degree order. The flux
 * at de[0..n_de-1]: flux[k] (NaN and fstat[k] = TUBES_ENOCONV where the truncated normal form has
 * no bounded action region). Out: lambda, omegas[N-1], the normal form H_NF = sum_t nf_coef[t]
 * I_1^nf_expo[3t] J_2^nf_expo[3t+1] J_3^nf_expo[3t+2] (n_nf <= max_nf terms, the constant E_s
 * included), diag = {max |C^T J C - J|, largest non-normal coefficient left, largest imaginary
 * part, smallest divisor}; msg the reason of a refusal (TUBES_EINPUT: not a saddle x centres,
 * degenerate, equal frequencies, a negative-energy centre; TUBES_ENOCONV: a resonance). nhim and
 * round_trip: below. */
int tubes_birkhoff(int n_dof, int order, int n_terms, const int expo[], const double coef[], int n_de,
                      const double de[], double flux[], int fstat[], double *lambda,
                      double omegas[TUBES_MAXDOF - 1], int max_nf, int *n_nf, int nf_expo[],
                      double nf_coef[], double diag[4], double nhim[], double round_trip[], char *msg,
                      int lmsg);
/* Points of the NHIM per energy that tubes_birkhoff maps to the model's coordinates: nhim[(k
 * TUBES_NF_NPTS + j) 2N + i] = component i of z - z_s of point j at de[k]; round_trip[k] the largest
 * |new(old(zeta)) - zeta| of the coordinate change and its inverse there (src/orbits/tubes_normal_form.f90). */
#define TUBES_NF_NPTS 8

/* Poincare map of the section at de: pts[(j n_iter + k) 2 + {0, 1}] = (r, p_r) of the k-th return
 * of seed j (NaN once it stops returning within t_max). */
int tubes_poincare(const char system[TUBES_LSYSTEM], const double params[TUBES_MAXPARAM],
                   const double lo[TUBES_MAXDOF], const double hi[TUBES_MAXDOF], int n_grid,
                   const char saddle[8], double de, int sec_kind, int sec_index,
                   double level, int dir, int n_seeds, int n_iter, double t_max, int method,
                   double h, double omega_bind, int solver, int max_iter, double pts[],
                   void *stores);

/* Frames per track of the synthetic experiment: t = 0, 1/camera_rate, ... up to duration [s]
 * (both ends included); 0 if duration or camera_rate is not > 0 or their product > 1e8. */
int tubes_experiment_samples(double duration, double camera_rate);

/* The synthetic experiment's release box [cm] and its integration tolerance rtol = atol: the
 * defaults of src/experiment/tubes_experiment.f90 (docs/experiment-data.md). */
void tubes_experiment_defaults(double *box, double *rtol);

/* Release point draws after which tubes_synthetic_experiment gives up (TUBES_EINPUT). */
enum { TUBES_MAX_RELEASE_DRAWS = 4194304 };

/* Synthetic tracking data (src/experiment/tubes_experiment.f90, docs/experiment-data.md): n_tracks balls
 * released from rest at points drawn uniformly in |x|, |y| <= box [cm] with g H - e_e in
 * [de_min, de_max] [(cm/s)^2], integrated by the method given (method .. max_iter as for
 * tubes_run_trajectory; rtol = atol = rtol) on the model with
 * damping ratio model[6], sampled at ns = tubes_experiment_samples(duration, camera_rate)
 * frames t[ns]; the measured position is the true one plus Gaussian noise of standard deviation
 * noise [cm], rounded to multiples of pixel [cm] (0: no rounding). GSL MT19937 from seed, drawn
 * serially: the result does not depend on the number of threads. Per track j and frame k
 * (block (j ns + k)): state[4] (x, y, px, py), energy (conservative), noisy[2] (before rounding),
 * measured[2]; release[3 j + {0, 1, 2}] = x0, y0, g H(x0, y0) - e_e. *c_damp: damping rate
 * [1/s]; *n_draws: release points drawn. TUBES_EINPUT also when n_tracks points were not found
 * within TUBES_MAX_RELEASE_DRAWS draws. */
int tubes_synthetic_experiment(const double params[TUBES_MAXPARAM], double e_e, int n_tracks,
                               double duration, double camera_rate, double pixel, double noise,
                               double de_min, double de_max, double box, int seed, double rtol,
                               int method, double h, double omega_bind, int solver, int max_iter,
                               int ns, double t[], double state[], double energy[], double noisy[],
                               double measured[], double release[], double *c_damp, int *n_draws);

#ifdef __cplusplus
}
#endif
#endif
