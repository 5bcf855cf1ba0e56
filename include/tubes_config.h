/* The driver's namelist input (src/io/tubes_nml.f90: Fortran's namelist READ behind bind(C);
 * validated by src/io/tubes_input.c). Not part of the library API (include/tubes.h): the program,
 * the fuzzer and the f2py layer's input reader use it. */
#ifndef TUBES_CONFIG_H
#define TUBES_CONFIG_H
#include <stdint.h>
#include "tubes.h"
#ifdef __cplusplus
extern "C" {
#endif

enum { TUBES_MAX_INPUT = 1 << 20 /* bytes of an input file at most */ };

/* tubes_config_t, the settings of a run, and the lengths of its fields (TUBES_NSCENES, TUBES_LNAME,
 * TUBES_MAXDE, ...): generated at build time from their one definition, the bind(C) type
 * tubes_config_t of src/workflow/tubes_config.f90, where each field is documented (src/io/tubes_config_gen.awk
 * writes build/include/tubes_config_fields.h). */
#include "tubes_config_fields.h"

/* Set every variable to its default. */
void tubes_nml_defaults(tubes_config_t *cfg);

/* Read every group present in the file at path into cfg (defaults first). Returns 0, or the
 * Fortran iostat of the first failing group; then *group is its index (0 run, 1 model,
 * 2 equilibria, 3 trajectory, 4 integrator, 5 orbits, 6 section, 7 tubes, 8 transition,
 * 9 montecarlo, 10 sections, 11 experiment, 12 flux) and msg holds the iomsg. */
int tubes_nml_read(const char *path, tubes_config_t *cfg, int *group, char *msg, int msglen);

/* sizeof(tubes_config_t) as Fortran lays it out (the reader checks C's against it). */
int tubes_nml_config_size(void);

/* The effective namelist (all groups, Fortran namelist WRITE) into buf. Returns its length,
 * or -1 if buf is too small. */
int tubes_nml_write(const tubes_config_t *cfg, char *buf, int buflen);

#ifdef __cplusplus
}
#endif
#endif
