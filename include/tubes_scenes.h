/* Scene drivers of the tubes program (src/io/tubes_scenes.c): each computes through the
 * bind(C) API, prints a short summary on stdout and writes its group of the HDF5 file. */
#ifndef TUBES_SCENES_H
#define TUBES_SCENES_H
#include <hdf5.h>
#include "tubes.h"
#ifdef __cplusplus
extern "C" {
#endif
/* Exit codes of the program (docs/usage.md). */
enum { EXIT_BADINPUT = 1, EXIT_NUMERIC = 2, EXIT_IO = 3, EXIT_PARTIAL = 4 };

typedef struct {
  const tubes_config_t *cfg;
  double model[TUBES_NMODEL];
  hid_t file;    /* rank 0: the output file; other MPI ranks: an in-memory scratch file */
  int rank;      /* MPI rank (0 without MPI): only rank 0 writes files */
  int nranks;    /* MPI ranks (1 without MPI) */
} tubes_run_t;

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
#ifdef __cplusplus
}
#endif
#endif
