/* The driver's namelist input (src/io/tubes_nml.f90: Fortran's namelist READ behind bind(C);
 * validated by src/io/tubes_input.c). Not part of the library API (include/tubes.h): the program,
 * the fuzzer and the f2py layer's input reader use it. */
#ifndef TUBES_CONFIG_H
#define TUBES_CONFIG_H
#include "tubes.h"
#ifdef __cplusplus
extern "C" {
#endif

enum { TUBES_NSCENES = 16, TUBES_LSCENE = 32, TUBES_LPATH = 1024, TUBES_LNAME = 32, TUBES_MAXDE = 256,
       TUBES_LSADDLE = 8 /* an equilibrium's name (tubes_equilibria.f90) */,
       TUBES_MAX_INPUT = 1 << 20 /* bytes of an input file at most */ };
/* models written as formulas: a formula, a name, a constant 'name = value', how many, a message */
enum { TUBES_LEXPR = 2048, TUBES_LSYM = 16, TUBES_LCONST = 128, TUBES_MAXCONST = 32, TUBES_LMSG = 1024 };

typedef struct {
  /* &run */
  char scenes[TUBES_NSCENES][TUBES_LSCENE];
  char output[TUBES_LPATH];
  /* &model */
  double alpha, beta, gamma, xi, h0, g, damping_ratio, rolling_resistance, noise_d, temperature;
  /* &equilibria */
  double box;
  int n_grid;
  char saddle[TUBES_LSADDLE];
  /* &trajectory */
  double x0, y0, px0, py0, t_end, dt_out;
  int at_rest;
  char section[TUBES_LNAME];
  double section_angle, section_level;
  int section_direction, max_crossings, stop_at_first;
  /* &integrator */
  char method[TUBES_LNAME];
  double rtol, atol, h;
  int64_t max_steps;
  double omega_bind;
  char solver[TUBES_LNAME];
  int max_iter;
  /* &orbits */
  char orb_saddle[TUBES_LSADDLE];
  double orb_de[TUBES_MAXDE];
  int orb_nde;
  char orb_method[TUBES_LNAME];
  int orb_n_segments, orb_max_iter, orb_n_samples;
  double orb_tol, orb_rtol, orb_atol;
  /* &section */
  double sec_angle;
  int sec_pth_sign;
  /* &tubes */
  double tub_de[TUBES_MAXDE];
  int tub_nde;
  char tub_kind[TUBES_LNAME];
  double tub_eps, tub_area_tol, tub_t_max;
  int tub_n_init, tub_n_max;
  /* &transition */
  double tra_de[TUBES_MAXDE];
  int tra_nde;
  double tra_area_tol;
  /* &montecarlo */
  double mc_de, mc_t_max, mc_gate, mc_area_tol;
  int mc_n_samples, mc_seed;
  /* &sections */
  double pm_de[TUBES_MAXDE];
  int pm_nde, pm_n_seeds, pm_n_iter;
  double pm_t_max;
  /* &experiment */
  int exp_n_tracks, exp_seed;
  double exp_duration, exp_camera_rate, exp_pixel, exp_noise, exp_de_min, exp_de_max,
      exp_damping_ratio, exp_rolling_resistance;
  char exp_csv[TUBES_LPATH];
  /* the any-Hamiltonian additions: &model system and the other systems' parameters (unset:
   * -DBL_MAX), &equilibria box (list) and box_center, &orbits saddle_near, &section kind, index,
   * direction, value */
  char system[TUBES_LNAME];
  double m_a, m_b, d, lambda, zeta, eps_s, omega, eps, mu;
  double box_list[TUBES_MAXDOF], box_center[TUBES_MAXDOF], orb_saddle_near[TUBES_MAXDOF];
  char sec_kind[TUBES_LNAME];
  int sec_index, sec_direction;
  double sec_value;
  /* resolved by the reader from the library's table (src/models/tubes_models.f90): the system's degrees
   * of freedom and parameters in the table's order (nparams = -1: unknown system), the search box,
   * whether the saddle is chosen by position; box_list, box_center, the section's fields, the
   * saddle and mc_gate then hold the effective values */
  int ndof, nparams, orb_use_near;
  double params[TUBES_MAXPARAM], box_lo[TUBES_MAXDOF], box_hi[TUBES_MAXDOF];
  /* models written as formulas (docs/models.md): &model hamiltonian, coordinates, momenta,
   * constants, surface, height; then model: the name the library knows the model by (the system's,
   * or expr_<hash> for a formula; nparams = -2 when building it failed: expr_var names the
   * variable at fault, expr_msg says why), expr_lib its shared library, expr_seconds the time
   * the build or the cache lookup took, expr_hit 1 for a cache hit */
  char hamiltonian[TUBES_LEXPR], coordinates[TUBES_MAXDOF][TUBES_LSYM], momenta[TUBES_MAXDOF][TUBES_LSYM],
      constants[TUBES_MAXCONST][TUBES_LCONST], surface[TUBES_LNAME], height[TUBES_LEXPR];
  /* &model dissipation: the laws the input declares ('' : not declared; checked against the
   * coefficients by nml_validate) */
  char dissipation[TUBES_LNAME];
  char model[TUBES_LNAME], expr_var[TUBES_LNAME], expr_msg[TUBES_LMSG], expr_lib[TUBES_LPATH];
  double expr_seconds;
  int expr_hit;
  /* &flux (docs/input.md); flux_gate resolved like mc_gate */
  double flux_de[TUBES_MAXDE];
  int flux_nde, flux_n_samples, flux_seed, flux_order, flux_n_cut;
  double flux_t_max, flux_gate, flux_tol, flux_cut_eps;
  int orb_family;   /* &orbits family: which centre mode's Lyapunov family (1 .. N-1) */
  int spatial;      /* &model spatial: the cr3bp in three dimensions (model cr3bp_spatial) */
  /* &scan (docs/scan.md): the parameter, its end value (unset: -DBL_MAX), the steps, the orbits' dE
   * (scan_nde 0: none; &orbits de when &scan de is not set and &orbits de is); scan_ipar resolved by
   * the reader: the parameter's index (1-based) in params, 0 when the scan does not take it */
  char scan_parameter[TUBES_LNAME];
  double scan_to;
  double scan_de[TUBES_MAXDE];
  int scan_n, scan_nde, scan_ipar;
  /* &orbits guess, period: a family from a guess (docs/orbits.md, "Orbits from a guess"); orb_nguess
   * the number of values given (0: none; the first 2 TUBES_MAXDOF kept); family = 'branch:K' is
   * orb_family = -100 - K */
  double orb_guess[2 * TUBES_MAXDOF];
  int orb_nguess;
  double orb_period;
  int scan_p_trans;   /* &scan p_trans: 1 = p_trans(dE) at each step (docs/scan.md) */
  /* &orbits jacobi, periods: the orbits by Jacobi constant or by period instead of dE (docs/orbits.md,
   * "Orbits by Jacobi constant or period"); orb_njacobi, orb_nperiods the number of values given (0:
   * none); orb_de_given 1 when &orbits de was given (else orb_de holds its default) */
  double orb_jacobi[TUBES_MAXDE];
  double orb_periods[TUBES_MAXDE];
  int orb_njacobi, orb_nperiods, orb_de_given;
} tubes_config_t;

/* Set every variable to its default. */
void tubes_nml_defaults(tubes_config_t *cfg);

/* Read every group present in the file at path into cfg (defaults first). Returns 0, or the
 * Fortran iostat of the first failing group; then *group is its index (0 run, 1 model,
 * 2 equilibria, 3 trajectory, 4 integrator, 5 orbits, 6 section, 7 tubes, 8 transition,
 * 9 montecarlo, 10 sections, 11 experiment, 12 flux) and msg holds the iomsg. */
int tubes_nml_read(const char *path, tubes_config_t *cfg, int *group, char *msg, int msglen);

/* The effective namelist (all groups, Fortran namelist WRITE) into buf. Returns its length,
 * or -1 if buf is too small. */
int tubes_nml_write(const tubes_config_t *cfg, char *buf, int buflen);

#ifdef __cplusplus
}
#endif
#endif
