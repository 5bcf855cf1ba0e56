/* Scene drivers of the tubes program (src/io/tubes_scenes.c): each computes through the
 * bind(C) API, prints a short summary on stdout and writes its group of the HDF5 file. */
#ifndef TUBES_SCENES_H
#define TUBES_SCENES_H
#include <hdf5.h>
#include "tubes_config.h"
#ifdef __cplusplus
extern "C" {
#endif
/* Exit codes of the program (docs/usage.md). */
enum { EXIT_BADINPUT = 1, EXIT_NUMERIC = 2, EXIT_IO = 3, EXIT_PARTIAL = 4 };

typedef struct {
  const tubes_config_t *cfg;
  char system[TUBES_LSYSTEM];                      /* the model (docs/models.md): the library's name */
  char label[64];                                  /* the model as messages name it */
  double params[TUBES_MAXPARAM];                   /* its parameters, in the table's order */
  int ndof;                                        /* N: states have 2 N components */
  int natural;                                     /* 1: H = T + V (brake orbits, rest points) */
  char length_units[8];                            /* units of the coordinates ("cm", "1") */
  double lo[TUBES_MAXDOF], hi[TUBES_MAXDOF];       /* the equilibrium search box */
  int n_grid;
  char saddle[8];                                  /* the chosen saddle (&orbits), resolved */
  const char *input;                               /* the input file, for messages */
  int eq_saddle_line, orb_saddle_line;             /* where &equilibria / &orbits saddle were set */
  int method_line;                                 /* where &integrator method was set */
  int scenes_line, sec_kind_line;                  /* where &run scenes, &section kind were set */
  const void *where;                               /* the input's nml_where (tubes_input.h): lines */
  int method;                                      /* its TUBES_METHOD_* ('auto' without a Taylor kernel: DOP853) */
  hid_t file;    /* rank 0: the output file; other MPI ranks: an in-memory scratch file */
  int rank;      /* MPI rank (0 without MPI): only rank 0 writes files */
  void *seeds;   /* the run's tube seeds (tubes_seed_stores_new): later scenes' cuts look them up */
  int nranks;    /* MPI ranks (1 without MPI) */
  double zeta;   /* the model's damping ratio (its parameter damping_ratio, 0 if none): scene_model */
  double crr;    /* its rolling resistance coefficient (rolling_resistance, 0 if none): scene_model */
  double c_damp, f_roll;   /* the viscous rate [1/s] and the rolling drag C_rr g [cm/s^2] they make */
  char dissip[128];        /* the dissipation in words ("" for a conservative model) */
  const char *law;         /* "viscous", "rolling", "noise" joined by "+" (NULL: conservative) */
  int noisy;               /* noise or temperature > 0: the Monte Carlo integrates the noisy model */
  double noise, temperature;   /* its noise D [(cm/s)^2/s] and temperature [(cm/s)^2] */
} tubes_run_t;

/* Fill the model, the box and the saddle of run from run->cfg; resolves &orbits saddle_near to
 * the nearest rank-1 saddle. Returns 0 or EXIT_BADINPUT / EXIT_NUMERIC (message printed). */
int run_setup(tubes_run_t *run);

/* Each returns 0, EXIT_NUMERIC (numerical failure, reported on stderr, recorded in the file)
 * or EXIT_IO. */
int scene_model(tubes_run_t *run);
int scene_equilibria(tubes_run_t *run);
int scene_trajectory(tubes_run_t *run);
/* Returns 0, EXIT_PARTIAL (some energies failed or lie past the family's end), EXIT_NUMERIC or EXIT_IO. */
int scene_orbits(tubes_run_t *run);
int scene_tubes(tubes_run_t *run);
int scene_transition(tubes_run_t *run);
int scene_montecarlo(tubes_run_t *run);
int scene_sections(tubes_run_t *run);
/* Synthetic tracking data (&experiment): writes /tracks, and the CSV file if &experiment csv is
 * set. Returns 0, EXIT_NUMERIC or EXIT_IO. */
int scene_synthetic_experiment(tubes_run_t *run);
/* The flux of trajectories through the saddle's bottleneck (/flux; src/transport/tubes_flux.f90). */
int scene_flux(tubes_run_t *run);
/* Continuation in a model parameter (&scan; /scan; src/workflow/tubes_scene_scan.f90). Returns 0, EXIT_PARTIAL
 * (an orbit not found at a step that has the saddle), EXIT_NUMERIC or EXIT_IO. */
int scene_scan(tubes_run_t *run);
/* The model scene (src/workflow/tubes_scene_model.f90) on the run's settings: natural and dimensioned (the
 * ball's units) its kind, input the input file ("" none). Its dissipation back (src/workflow/tubes_setup.f90
 * model_dissipation): law and text (lens bytes each), v = (damping_ratio, rolling_resistance, noise,
 * temperature, c [1/s], f [cm/s^2]). The record's handle. */
int tubes_model_scene(const tubes_config_t *cfg, int natural, int dimensioned, const char *input, char *law,
                      char *text, int lens, double v[6]);

/* The first of a group's n excess energies des below what the energy resolves at the saddle of energy ee
 * (src/workflow/tubes_setup.f90 de_unresolved): its index (1-based) and the message in msg (len bytes), or 0. */
int tubes_de_unresolved(int n, const double *des, const char *group, const char *saddle, double ee, char *msg, int len);
/* The paper's defaults (the excess energies of group's scene, group "trajectory": the start) for model:
 * 0, or 1 with the message's body in msg (src/workflow/tubes_setup.f90 default_refused). */
int tubes_default_refused(const char *model, const char *group, const char *label, char *msg, int len);

/* The core's scenes on the run's settings (src/workflow/tubes_scene_<name>.f90, entered through
 * src/capi/tubes_capi_record.f90): cfg as the reader left it, the saddle and the method the run chose
 * (run_setup), who the input file in messages, the run's stores. Each returns its record's handle. */
/* The equilibria scene: the saddle want (asked: the input names it), label (the model in messages), dissip
 * (the dissipation in words, "" conservative). */
int tubes_equilibria_scene(const tubes_config_t *cfg, const char want[8], int asked, const char label[64],
                           const char dissip[128], void *stores);
int tubes_flux_scene(const tubes_config_t *cfg, const char saddle[8], int method, const char *who, void *stores);
/* units: the messages carry the ball's units (cm, (cm/s)^2, cm/s); dissip: the dissipation in words ("" for
 * a conservative model); written: /section is in the output already. */
int tubes_transition_scene(const tubes_config_t *cfg, const char saddle[8], int method, int units,
                           const char dissip[128], int written, void *stores);
/* noisy: the model carries noise; gate_at: the head of a message about &montecarlo gate ("FILE:LINE: "). */
int tubes_montecarlo_scene(const tubes_config_t *cfg, const char saddle[8], int method, int units,
                           const char dissip[128], int noisy, const char gate_at[1024], int written, void *stores);
/* length: the coordinates' units in words; check_eps: each cut repeated with eps/10 (the program does). */
/* Map k (0-based, /sections/map_k) of the sections scene; dissipative: the model loses energy (its
 * line says so). */
int tubes_sections_scene(const tubes_config_t *cfg, const char saddle[8], int method, int k, int dissipative,
                         void *stores);
/* /section alone, for a scene that draws on the section without its own use of it (sections). */
int tubes_section_scene(const tubes_config_t *cfg, const char saddle[8], int method, int written, void *stores);
int tubes_synthetic_experiment_scene(const tubes_config_t *cfg, const char saddle[8], int method, void *stores);
/* The trajectory scene with the run's dissipation (zeta, crr, f_roll [cm/s^2], dissip in words, "" for a
 * conservative model), label the model in messages, input the input file, us and ue the units written
 * after a time and an energy ("" dimensionless). */
int tubes_trajectory_scene(const tubes_config_t *cfg, int method, double zeta, double crr, double f_roll,
                           const char *dissip, const char label[64], const char *input, const char *us, const char *ue,
                           void *stores);
/* The orbits scene (&orbits de, or jacobi, or periods); dimensioned: the ball's units (cm, s); dissipative:
 * the run's model dissipates (its orbits are the conservative model's). */
int tubes_orbits_scene(const tubes_config_t *cfg, const char saddle[8], int method, int dimensioned, int dissipative,
                       void *stores);
/* The scan scene (&scan); dissip: the dissipation in words ("" conservative), input the input's name in
 * messages. */
int tubes_scan_scene(const tubes_config_t *cfg, const char saddle[8], int method, const char dissip[128],
                     const char *input);
int tubes_tubes_scene(const tubes_config_t *cfg, const char saddle[8], int method, int units, const char length[32],
                      const char dissip[128], int check_eps, int written, void *stores);
#ifdef __cplusplus
}
#endif
#endif
