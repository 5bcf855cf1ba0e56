/* Small helpers over the HDF5 C API for tubes' output (src/io/tubes_h5.c). Every function
 * returns 0 on success and -1 on failure (HDF5's own error stack is silenced). */
#ifndef TUBES_H5_H
#define TUBES_H5_H
#include <hdf5.h>
#ifdef __cplusplus
extern "C" {
#endif
/* Create path.tmp.<pid> for writing; its name is returned in tmp. */
hid_t h5_create_tmp(const char *path, char *tmp, size_t tmplen);
/* Close and rename tmp to path (the file appears only when complete). */
int h5_commit(hid_t f, const char *tmp, const char *path);
/* Close and delete tmp. */
void h5_discard(hid_t f, const char *tmp);
/* An in-memory file that is never written to disk (the MPI ranks other than 0 write their copy
 * of the output there, so that every rank runs the same code; docs/cluster.md). */
hid_t h5_create_scratch(void);
/* A model without physical units (every system but the rolling ball, docs/output.md): the units
 * the scenes give, the ball's (cm, s), are written as the model's ("1"; "rad/s" as "rad"). */
void h5_set_dimensionless(int on);
/* A units text as this file writes it (the ball's as given; a dimensionless model's, above). */
const char *h5_units(const char *units);
/* A function called whenever a write fails (before the helper returns -1), or NULL. */
void h5_set_failure_hook(void (*hook)(void));
hid_t h5_group(hid_t loc, const char *name);
/* The names of f's root links, joined by '\n' into buf (0; -1 when they do not fit), and the removal
 * of every root link not in such a list (what an interrupted scene wrote; 0 or -1). */
int h5_root_links(hid_t f, char *buf, size_t len);
int h5_drop_links_since(hid_t f, const char *before);
int h5_attr_double(hid_t loc, const char *name, double v);
int h5_attr_long(hid_t loc, const char *name, long long v);
int h5_attr_string(hid_t loc, const char *name, const char *s);
/* Datasets: rank 1 or 2 (dims in C order), with a `units` attribute. */
int h5_write_double(hid_t loc, const char *name, int rank, const hsize_t *dims, const double *data,
                    const char *units);
int h5_write_int(hid_t loc, const char *name, hsize_t n, const int *data, const char *units);
int h5_write_int_nd(hid_t loc, const char *name, int rank, const hsize_t *dims, const int *data, const char *units);
int h5_write_strings(hid_t loc, const char *name, hsize_t n, const char *const *s);
#ifdef __cplusplus
}
#endif
#endif
