/* The units of the output's quantities (include/tubes_units.h): one table, read by the HDF5 writer
 * (a dataset written with units NULL takes its row's) and by Python (tubes.Table.units, through
 * the core's dataset_units). Units are the rolling ball's (cm, s); a dimensionless model's file
 * writes them as h5_units' rule makes them ("1"; "rad/s" as "rad"). docs/output.md lists them.
 * Not here: the states (their units depend on the model's degrees of freedom: given where they are
 * written, "cm, cm, cm/s, cm/s" for the ball, else "state units") and the names (strings). */
#include "tubes_units.h"
#include "tubes_input.h"
#include <ctype.h>
#include <stdio.h>
#include <string.h>

typedef struct {
  const char *group;   /* the group's path, a run of digits written '#' (/tubes/stable_003: /tubes/stable_#) */
  const char *name;    /* the dataset's, or attribute's, name */
  const char *units;   /* the rolling ball's units */
} unit_row_t;

#define TRANSITION_ROWS(G)                                                                              \
  {G, "dE", "(cm/s)^2"}, {G, "A_tube", "cm^2/s"}, {G, "action", "cm^2/s"}, {G, "A_E", "cm^2/s"},       \
  {G, "p_trans", "1"}, {G, "p_trans_leading", "1"}, {G, "status", "1"}, {G, "A_region", "cm^2/s"},       \
  {G, "p_trans_conservative", "1"}, {G, "status_conservative", "1"}, {G, "region_rays", "1"}
#define CUT_ROWS(G)                                                                                     \
  {G, "r", "cm"}, {G, "p_r", "cm/s"}, {G, "tau", "s"}, {G, "time", "s"}, {G, "history_area", "cm^2/s"}, \
  {G, "history_n", "1"}, {G, "dE", "(cm/s)^2"}, {G, "area", "cm^2/s"}, {G, "area_polygon", "cm^2/s"},  \
  {G, "action", "cm^2/s"}, {G, "period", "s"}, {G, "eps", "cm"}, {G, "area_eps10", "cm^2/s"},          \
  {G, "area_eps_change", "cm^2/s"}

static const unit_row_t ROWS[] = {
  /* the equilibria scene */
  {"/equilibria", "x", "cm"}, {"/equilibria", "y", "cm"}, {"/equilibria", "height", "cm"},
  {"/equilibria", "energy", "(cm/s)^2"}, {"/equilibria", "lambda", "1/s"}, {"/equilibria", "omega", "rad/s"},
  {"/equilibria", "frequencies", "rad/s"}, {"/equilibria", "morse_index", "1"}, {"/equilibria", "grad_norm", "1"},
  {"/equilibria", "stable", "1"}, {"/equilibria", "omegas", "rad/s"}, {"/equilibria", "rank1", "1"},
  {"/equilibria", "eigenvectors", "1"},
  {"/saddle", "eigenvectors", "1"}, {"/saddle", "damped_eigenvalues", "1/s"},
  /* the orbits scene */
  {"/orbits", "dE", "(cm/s)^2"}, {"/orbits", "energy", "(cm/s)^2"}, {"/orbits", "period", "s"},
  {"/orbits", "action", "cm^2/s"}, {"/orbits", "closure", "cm, cm/s"}, {"/orbits", "residual", "cm, cm/s"},
  {"/orbits", "min_eq_distance", "cm"}, {"/orbits", "converged", "1"}, {"/orbits", "iterations", "1"},
  {"/orbits", "mu_stable", "1"}, {"/orbits", "mu_unstable", "1"}, {"/orbits", "mu_trivial", "1"},
  {"/orbits", "mu_trivial_imag", "1"}, {"/orbits", "stability_index", "1"}, {"/orbits", "monodromy", "1"},
  {"/orbits", "end_dE", "(cm/s)^2"}, {"/orbits/orbit_#", "history", "cm, cm/s"}, {"/orbits/orbit_#", "t", "s"},
  {"/orbits", "floquet_index", "1"}, {"/orbits", "floquet_index_imag", "1"},
  {"/orbits", "jacobi", "(cm/s)^2"}, {"/orbits", "requested_jacobi", "(cm/s)^2"}, {"/orbits", "requested_period", "s"},
  {"/orbits/bifurcations", "kind", "1"}, {"/orbits/bifurcations", "after", "1"},
  {"/orbits/bifurcations", "converged", "1"}, {"/orbits/bifurcations", "dE", "(cm/s)^2"},
  {"/orbits/bifurcations", "bracket", "(cm/s)^2"}, {"/orbits/bifurcations", "energy", "(cm/s)^2"},
  {"/orbits/bifurcations", "period", "s"}, {"/orbits/bifurcations", "floquet_index", "1"},
  {"/orbits/bifurcations", "floquet_index_imag", "1"}, {"/orbits/bifurcations", "tangent", "1"},
  /* the scan scene (value and folds/value, bracket: the parameter's units, written with them) */
  {"/scan", "n_equilibria", "1"}, {"/scan", "researched", "1"}, {"/scan", "eq_q", "cm"},
  {"/scan", "eq_energy", "(cm/s)^2"}, {"/scan", "eq_index", "1"}, {"/scan", "eq_det", "1"},
  {"/scan", "saddle_found", "1"}, {"/scan", "saddle_q", "cm"}, {"/scan", "saddle_energy", "(cm/s)^2"},
  {"/scan", "lambda", "1/s"}, {"/scan", "omega", "rad/s"}, {"/scan", "dE", "(cm/s)^2"}, {"/scan", "period", "s"},
  {"/scan", "action", "cm^2/s"}, {"/scan", "stability_index", "1"}, {"/scan", "converged", "1"},
  {"/scan", "restarted", "1"}, {"/scan/folds", "kind", "1"}, {"/scan/folds", "step", "1"},
  {"/scan/folds", "q", "cm"}, {"/scan", "p_trans", "1"}, {"/scan", "A_tube", "cm^2/s"}, {"/scan", "A_E", "cm^2/s"},
  {"/scan", "p_trans_status", "1"},
  /* the transition scene */
  TRANSITION_ROWS("/transition"),
  /* the Monte Carlo scene */
  {"/montecarlo", "r", "cm"}, {"/montecarlo", "p_r", "cm/s"}, {"/montecarlo", "transit", "1"},
  {"/montecarlo", "inside", "1"}, {"/montecarlo", "dE", "(cm/s)^2"}, {"/montecarlo", "fraction", "1"},
  {"/montecarlo", "std_error", "1"}, {"/montecarlo", "p_trans", "1"},
  /* the tubes scene: the cuts, and a damped model's transition regions */
  CUT_ROWS("/tubes/stable_#"), CUT_ROWS("/tubes/unstable_#"),
  {"/tubes/region_#", "r", "cm"}, {"/tubes/region_#", "p_r", "cm/s"}, {"/tubes/region_#", "curve_r", "cm"},
  {"/tubes/region_#", "curve_p_r", "cm/s"}, {"/tubes/region_#", "phi", "rad"}, {"/tubes/region_#", "rho", "1"},
  {"/tubes/region_#", "t_in", "s"}, {"/tubes/region_#", "centre", "cm, cm/s"},
  {"/tubes/region_#", "scale", "cm, cm/s"}, {"/tubes/region_#", "dE", "(cm/s)^2"},
  {"/tubes/region_#", "area", "cm^2/s"}, {"/tubes/region_#", "p_trans", "1"},
  /* the sections scene */
  {"/sections/map_#", "points", "cm, cm/s"}, {"/sections/map_#", "dE", "(cm/s)^2"},
  /* the synthetic experiment */
  {"/tracks", "t", "s"}, {"/tracks", "track", "1"}, {"/tracks", "x", "cm"}, {"/tracks", "y", "cm"},
  {"/tracks/truth", "dE", "(cm/s)^2"}, {"/tracks/truth", "energy", "(cm/s)^2"}, {"/tracks/truth", "noisy", "cm"},
  {"/tracks/truth", "release", "cm"}, {"/tracks/truth", "release_dE", "(cm/s)^2"},
  /* the 3-DOF flux scene (generic units: any model's) */
  {"/flux", "dE", "energy"}, {"/flux", "flux_leading_order", "action^(N-1)"},
  {"/flux", "flux_normal_form", "action^(N-1)"}, {"/flux", "flux_normal_form_change", "action^(N-1)"},
  {"/flux", "flux_sampled", "action^(N-1)"}, {"/flux", "flux_sampled_err", "action^(N-1)"},
  {"/flux", "n_inside", "1"}, {"/flux", "n_reacting", "1"}, {"/flux", "n_recrossing", "1"},
  {"/flux", "n_undecided", "1"}, {"/flux", "nhim_energy_error", "1"}, {"/flux", "round_trip_error", "1"},
  {"/flux", "status", "1"},
  {"/flux/section", "n_inside", "1"}, {"/flux/section", "n_return", "1"}, {"/flux/section", "n_transit", "1"},
  {"/flux/section", "n_undecided", "1"}, {"/flux/section", "p_trans", "1"}, {"/flux/section", "p_trans_err", "1"},
  {"/flux/section", "p_trans_theory", "1"}, {"/flux/section", "volume", "action^(N-1)"},
  {"/flux/section", "volume_err", "action^(N-1)"},
  {"/flux/tube_cut", "inside", "1"}, {"/flux/tube_cut", "inside_pl", "1"}, {"/flux/tube_cut", "misclassified", "1"},
  {"/flux/tube_cut", "misclassified_pl", "1"}, {"/flux/tube_cut", "outcome", "1"},
  {"/flux/tube_cut", "p_trans_tube", "1"}, {"/flux/tube_cut", "seed_energy_error", "1"},
  {"/flux/tube_cut", "status", "1"}, {"/flux/tube_cut", "time", "time"}, {"/flux/tube_cut", "unresolved", "1"},
  {"/flux/tube_cut", "volume", "action^2"}, {"/flux/tube_cut", "volume_extrapolated", "action^2"},
  {"/flux/tube_cut", "volume_half", "action^2"}, {"/flux/tube_cut", "weight", "momentum^2"},
  {"/flux/normal_form", "coefficients", "energy / action^|powers|"}, {"/flux/normal_form", "omegas", "1/time"},
  {"/flux/normal_form", "power_I1", "1"}, {"/flux/normal_form", "power_J2", "1"},
  {"/flux/normal_form", "power_J3", "1"},
  /* the trajectory scene */
  {"/trajectory", "t", "s"}, {"/trajectory", "energy", "(cm/s)^2"}, {"/trajectory/crossings", "t", "s"},
  {"/trajectory/crossings", "r", "cm"}, {"/trajectory/crossings", "p_r", "cm/s"},
  {"/trajectory/crossings", "p_theta", "cm^2/s"}, {"/trajectory/crossings", "direction", "1"},
};

/* path with every run of digits as '#' (at most len - 1 characters) */
static void pattern(const char *path, char *out, size_t len) {
  size_t j = 0;
  for (const char *p = path; *p && j + 1 < len; p++) {
    if (isdigit((unsigned char)*p)) {
      out[j++] = '#';
      while (isdigit((unsigned char)p[1])) p++;
    } else
      out[j++] = *p;
  }
  out[j] = '\0';
}

const char *tubes_units_of(const char *group, const char *name) {
  char g[256];
  pattern(group, g, sizeof g);
  for (size_t k = 0; k < sizeof ROWS / sizeof ROWS[0]; k++)
    if (!strcmp(ROWS[k].group, g) && !strcmp(ROWS[k].name, name)) return ROWS[k].units;
  return NULL;
}

/* h5_units' rule (src/io/tubes_h5.c) for a model given as dimensionless or not */
const char *tubes_units_as(const char *units, int dimensionless) {
  if (!dimensionless || !units) return units;
  if (!strcmp(units, "rad/s")) return "rad";
  if (tubes_units_dimensioned(units)) return "1";
  return units;
}

int tubes_units_c(const char *group, const char *name, int dimensionless, char *out, int len) {
  const char *u = tubes_units_as(tubes_units_of(group, name), dimensionless);
  if (len > 0) snprintf(out, (size_t)len, "%s", u ? u : "");
  return u ? 0 : -1;
}
