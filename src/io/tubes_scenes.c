/* Scene drivers (include/tubes_scenes.h). */
#include "tubes_scenes.h"
#include "tubes_record.h"
#include "tubes_h5.h"
#include "tubes_input.h"
#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#ifdef TUBES_MPI
#include <mpi.h>
#endif

/* " <units>" in a message: the rolling ball's units as given, nothing for a dimensionless model
 * (h5_units). */
static const char *in_units(const char *ball_units) {
  return strcmp(h5_units(ball_units), "1") ? ball_units : "";
}


/* Does the run's model dissipate (damping_ratio or rolling_resistance > 0; scene_model)? */
static int dissipative(const tubes_run_t *run) { return run->law != NULL; }


enum { NEQ_MAX = 256, MD = TUBES_MAXDOF };

/* The model scene: src/workflow/tubes_scene_model.f90 (its record written by record_emit); the run
 * keeps its dissipation (law, rates and sentence) for the other scenes. */
int scene_model(tubes_run_t *run) {
  static char law[128];
  double v[6];
  const tubes_config_t *c = run->cfg;
  int h = tubes_model_scene(c, run->natural, in_units(" 1/s")[0] != 0, run->input ? run->input : "", law, run->dissip,
                            (int)sizeof run->dissip, v);
  run->zeta = v[0];    /* the built-in ball's &model damping_ratio, or a formula surface's */
  run->crr = v[1];
  run->noise = v[2];
  run->temperature = v[3];
  run->noisy = v[2] > 0 || v[3] > 0;
  run->c_damp = v[4];
  run->f_roll = v[5];
  run->law = law[0] ? law : NULL;
  return record_emit(run->file, h);
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

/* The scenes' default excess energies and the trajectory's default start are the paper's: a model
 * without them must set them (tubes_setup default_refused, which Python's calls apply alike), said
 * with the line of &run scenes. des: the excess energies (else the trajectory's start). Checked after
 * the scene and saddle checks, whose messages say more. */
static int defaults_given(const tubes_run_t *run, int des) {
  const tubes_config_t *c = run->cfg;
  char m[1024];
  int n = 0;
  if (!des) {
    /* both: one alone would start other models at the ball's value of the other */
    if (scene_asked(c, "trajectory") &&
        (!nml_line(run->where, "trajectory", "x0") || !nml_line(run->where, "trajectory", "y0")) &&
        tubes_default_refused(run->system, "trajectory", run->label, m, (int)sizeof m)) {
      say_at(run, nml_line(run->where, "run", "scenes"));
      fprintf(stderr, "%s\n", m);
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
    if (!tubes_default_refused(run->system, g, run->label, m, (int)sizeof m)) continue;
    say_at(run, nml_line(run->where, "run", "scenes"));
    fprintf(stderr, "%s\n", m);
    n++;
  }
  return n ? EXIT_BADINPUT : 0;
}

/* Every dE the scenes ask for is resolvable against the saddle's energy E_e (tubes_de_floor, the
 * library's rule, which its calls also apply: TUBES_EUNRESOLVED), said before any work with the
 * file and line. 0, or EXIT_BADINPUT with the reason. */
static int de_resolvable(const tubes_run_t *run, double ee) {
  const tubes_config_t *c = run->cfg;
  if (defaults_given(run, 1)) return EXIT_BADINPUT;
  const struct { const char *scene, *group; const double *de; int n; } lists[] = {
      {"orbits", "orbits", c->orb_de, c->orb_njacobi + c->orb_nperiods > 0 ? 0 : c->orb_nde},
      {"tubes", "tubes", c->tub_de, c->tub_nde},
      {"transition", "transition", c->tra_de, c->tra_nde}, {"montecarlo", "montecarlo", &c->mc_de, 1},
      {"sections", "sections", c->pm_de, c->pm_nde},    {"flux", "flux", c->flux_de, c->flux_nde}};
  for (size_t j = 0; j < sizeof lists / sizeof lists[0]; j++) {
    if (!scene_asked(c, lists[j].scene)) continue;
    char m[1024];
    if (tubes_de_unresolved(lists[j].n, lists[j].de, lists[j].group, run->saddle, ee, m, (int)sizeof m)) {
      say_at(run, nml_line(run->where, lists[j].group, "de"));
      fprintf(stderr, "%s\n", m);
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
  if (integrates) {   /* 'taylor' and 'auto' need the model's kernel: built before any output */
    char m[1024];
    int code = tubes_method_resolved(run->method, run->system, run->params, c->rtol, m, (int)sizeof m);
    if (code == 0) {
      say_at(run, run->method_line);
      fprintf(stderr, "&integrator: method = 'taylor': no Taylor kernel for %s: %s\n", run->label, m);
      return EXIT_BADINPUT;
    }
    if (code != run->method && run->rank == 0)
      fprintf(stderr, "tubes: &integrator method = 'auto': DOP853 throughout (no Taylor kernel for %s: %s)\n",
              run->label, m);
    run->method = code;
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
  /* the saddle by name, or the nearest to saddle_near, among the equilibria in the box (tubes_setup
   * run_saddle, Python's too); &equilibria saddle, the one the equilibria scene reports, is checked too */
  char m[2048], chosen[8];
  double e_saddle;
  int code = 0;
  if (c->saddle[0]) {
    code = tubes_run_saddle(run->system, run->params, run->lo, run->hi, run->n_grid, run->seeds, c->saddle, 0,
                            c->orb_saddle_near, degenerate_ok(c), run->label, 0, chosen, &e_saddle, m, (int)sizeof m);
    if (code > 0) {
      say_at(run, run->eq_saddle_line);
      fprintf(stderr, "&equilibria: %s\n", m);
      return EXIT_BADINPUT;
    }
  }
  if (code == 0)
    code = tubes_run_saddle(run->system, run->params, run->lo, run->hi, run->n_grid, run->seeds, run->saddle,
                            c->orb_use_near, c->orb_saddle_near, degenerate_ok(c), run->label,
                            !c->orb_use_near && !run->orb_saddle_line, chosen, &e_saddle, m, (int)sizeof m);
  if (code < 0) {
    fprintf(stderr, "tubes: %s\n", m);
    return EXIT_NUMERIC;
  }
  if (code > 0) {
    int ln = c->orb_use_near ? nml_line(run->where, "orbits", "saddle_near") : run->orb_saddle_line;
    say_at(run, ln);
    if (c->orb_use_near) fprintf(stderr, "&orbits saddle_near%s: %s\n", ln ? "" : " (the system's default)", m);
    else fprintf(stderr, "&orbits: %s\n", m);
    return EXIT_BADINPUT;
  }
  snprintf(run->saddle, sizeof run->saddle, "%s", chosen);
  return de_resolvable(run, e_saddle);
}

/* The equilibria scene: src/workflow/tubes_scene_equilibria.f90 (its record written by
 * record_emit). */
int scene_equilibria(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_equilibria_scene(c, c->saddle[0] ? c->saddle : run->saddle, saddle_asked(c), run->label,
                                 dissipative(run) ? run->dissip : "", run->seeds);
  return record_emit(run->file, h);
}

int scene_trajectory(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_trajectory_scene(c, run->method, run->zeta, run->crr, run->f_roll, dissipative(run) ? run->dissip : "",
                                 run->label, run->input ? run->input : "tubes", in_units(" s"), in_units(" (cm/s)^2"),
                                 run->seeds);
  return record_emit(run->file, h);
}

/* The orbits scene: src/workflow/tubes_scene_orbits.f90 (its record written by record_emit), at
 * &orbits de, or at the orbits of &orbits jacobi or periods. */
int scene_orbits(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_orbits_scene(c, run->saddle, run->method, !strcmp(run->length_units, "cm"), dissipative(run),
                             run->seeds);
  return record_emit(run->file, h);
}

/* ---------------------------------------------------------------- tube dynamics scenes */


/* The tubes scene: src/workflow/tubes_scene_tubes.f90 (its record written by record_emit); /tubes
 * is made where no cut was recorded. */
int scene_tubes(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  char length[32];
  snprintf(length, sizeof length, "%s", strcmp(run->length_units, "1") ? run->length_units : "(length units)");
  int h = tubes_tubes_scene(c, run->saddle, run->method, in_units(" cm")[0] != 0, length,
                            dissipative(run) ? run->dissip : "", 1, H5Lexists(run->file, "section", H5P_DEFAULT) > 0,
                            run->seeds);
  int rc = record_emit(run->file, h);
  if (rc == EXIT_IO || H5Lexists(run->file, "section", H5P_DEFAULT) <= 0 || H5Lexists(run->file, "tubes", H5P_DEFAULT) > 0)
    return rc;
  hid_t g = h5_group(run->file, "tubes");
  if (g < 0) return EXIT_IO;
  H5Gclose(g);
  return rc;
}

/* The transition scene: src/workflow/tubes_scene_transition.f90 (its record written by record_emit;
 * its energies dealt out over the MPI ranks there). */
int scene_transition(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_transition_scene(c, run->saddle, run->method, in_units(" cm")[0] != 0,
                                 dissipative(run) ? run->dissip : "", H5Lexists(run->file, "section", H5P_DEFAULT) > 0,
                                 run->seeds);
  return record_emit(run->file, h);
}

/* The montecarlo scene: src/workflow/tubes_scene_montecarlo.f90 (its record written by record_emit). */
int scene_montecarlo(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  char at[1024];   /* the head of a message about &montecarlo gate (say_at's) */
  int ln = nml_line(run->where, "montecarlo", "gate");
  if (run->input && ln > 0) snprintf(at, sizeof at, "%s:%d: ", run->input, ln);
  else if (run->input) snprintf(at, sizeof at, "%s: ", run->input);
  else snprintf(at, sizeof at, "tubes: ");
  int h = tubes_montecarlo_scene(c, run->saddle, run->method, in_units(" cm")[0] != 0,
                                 dissipative(run) ? run->dissip : "", run->noisy, at,
                                 H5Lexists(run->file, "section", H5P_DEFAULT) > 0, run->seeds);
  return record_emit(run->file, h);
}

int scene_sections(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int rc = record_emit(run->file, tubes_section_scene(c, run->saddle, run->method,
                                                      H5Lexists(run->file, "section", H5P_DEFAULT) > 0, run->seeds));
  if (rc) return rc;
  hid_t g = h5_group(run->file, "sections");
  if (g < 0) return EXIT_IO;
  H5Gclose(g);
  for (int k = 0; k < c->pm_nde; k++) {   /* a map's record written before the next starts */
    int h = tubes_sections_scene(c, run->saddle, run->method, k, dissipative(run), run->seeds);
    int r = record_emit(run->file, h);
    if (r == EXIT_IO || r == EXIT_NUMERIC) return r;
    if (r) rc = r;
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
  int h = tubes_synthetic_experiment_scene(c, run->saddle, run->method, run->seeds);
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

/* The flux scene: src/workflow/tubes_scene_flux.f90 (its record written by record_emit). */
int scene_flux(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_flux_scene(c, run->saddle, run->method, run->input ? run->input : "tubes", run->seeds);
  return record_emit(run->file, h);
}

/* The scan scene: src/workflow/tubes_scene_scan.f90 (its record written by record_emit). */
int scene_scan(tubes_run_t *run) {
  const tubes_config_t *c = run->cfg;
  int h = tubes_scan_scene(c, run->saddle, run->method, dissipative(run) ? run->dissip : "",
                           run->input ? run->input : "tubes");
  return record_emit(run->file, h);
}
