/* The units of the output's quantities: one table (src/io/tubes_units.c) that the HDF5 writer and
 * Python's tubes.Table read. */
#ifndef TUBES_UNITS_H
#define TUBES_UNITS_H
#ifdef __cplusplus
extern "C" {
#endif
/* The rolling ball's units of dataset (or attribute) name in group (a path such as
 * "/tubes/stable_003"), or NULL when the table has no row for it. */
const char *tubes_units_of(const char *group, const char *name);
/* units as a file of the model writes them: as given for the ball, "1" ("rad/s": "rad") for a
 * dimensionless model. */
const char *tubes_units_as(const char *units, int dimensionless);
/* Both, into out (len bytes; "" without a row): 0, or -1 without a row. For Fortran (bind(C)). */
int tubes_units_c(const char *group, const char *name, int dimensionless, char *out, int len);
#ifdef __cplusplus
}
#endif
#endif
