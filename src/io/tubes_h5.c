/* HDF5 output helpers (include/tubes_h5.h). Strings are variable-length UTF-8 so that h5py
 * returns str, not bytes. */
#include <errno.h>
#include <fcntl.h>
#include "tubes_h5.h"
#include "tubes_input.h"
#include "tubes_units.h"
#include <stdio.h>
#include <string.h>
#include <unistd.h>

hid_t h5_create_tmp(const char *path, char *tmp, size_t tmplen) {
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
  snprintf(tmp, tmplen, "%s.tmp.%ld", path, (long)getpid());
  /* open(2) first: HDF5 does not pass on why a file cannot be created; errno tells the caller */
  int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) return -1;
  close(fd);
  hid_t f = H5Fcreate(tmp, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) {
    int e = errno ? errno : EIO;
    remove(tmp);
    errno = e;
  }
  return f;
}

int h5_commit(hid_t f, const char *tmp, const char *path) {
  if (H5Fclose(f) < 0) { remove(tmp); return -1; }
  if (rename(tmp, path) != 0) { remove(tmp); return -1; }
  return 0;
}

void h5_discard(hid_t f, const char *tmp) {
  if (f >= 0) H5Fclose(f);
  remove(tmp);
}

hid_t h5_create_scratch(void) {
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  if (fapl < 0) return -1;
  hid_t f = -1;
  if (H5Pset_fapl_core(fapl, 1 << 20, 0) >= 0)    /* 1 MiB increments, no backing store */
    f = H5Fcreate("tubes-scratch.h5", H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  H5Pclose(fapl);
  return f;
}

static void (*failure_hook)(void) = NULL;
void h5_set_failure_hook(void (*hook)(void)) { failure_hook = hook; }
static int failed(int rc) {
  if (rc && failure_hook) failure_hook();
  return rc;
}

hid_t h5_group(hid_t loc, const char *name) {
  hid_t g = H5Gcreate2(loc, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  failed(g < 0);
  return g;
}

typedef struct {
  char *buf;
  size_t len, used;
  int full;
} link_list_t;

static herr_t add_link(hid_t g, const char *name, const H5L_info_t *info, void *data) {
  (void)g, (void)info;
  link_list_t *l = data;
  size_t n = strlen(name);
  if (l->used + n + 2 > l->len) {
    l->full = 1;
    return 1;
  }
  memcpy(l->buf + l->used, name, n);
  l->used += n;
  l->buf[l->used++] = '\n';
  l->buf[l->used] = 0;
  return 0;
}

int h5_root_links(hid_t f, char *buf, size_t len) {
  link_list_t l = {buf, len, 0, 0};
  if (len < 2) return -1;
  buf[0] = 0;
  if (H5Literate(f, H5_INDEX_NAME, H5_ITER_NATIVE, NULL, add_link, &l) < 0 || l.full) return -1;
  return 0;
}

static int listed(const char *list, const char *name) {
  size_t n = strlen(name);
  for (const char *p = list; *p;) {
    const char *e = strchr(p, '\n');
    if (!e) break;
    if ((size_t)(e - p) == n && !strncmp(p, name, n)) return 1;
    p = e + 1;
  }
  return 0;
}

int h5_drop_links_since(hid_t f, const char *before) {
  char now[4096];
  if (h5_root_links(f, now, sizeof now)) return -1;
  int rc = 0;
  for (char *p = now; *p;) {
    char *e = strchr(p, '\n');
    *e = 0;
    if (!listed(before, p) && H5Ldelete(f, p, H5P_DEFAULT) < 0) rc = -1;
    p = e + 1;
  }
  return rc;
}

static int attr(hid_t loc, const char *name, hid_t type, const void *v) {
  hid_t sp = H5Screate(H5S_SCALAR);
  hid_t a = H5Acreate2(loc, name, type, sp, H5P_DEFAULT, H5P_DEFAULT);
  int rc = (a < 0 || H5Awrite(a, type, v) < 0) ? -1 : 0;
  if (a >= 0) H5Aclose(a);
  H5Sclose(sp);
  return failed(rc);
}

int h5_attr_double(hid_t loc, const char *name, double v) { return attr(loc, name, H5T_NATIVE_DOUBLE, &v); }
int h5_attr_long(hid_t loc, const char *name, long long v) { return attr(loc, name, H5T_NATIVE_LLONG, &v); }

static hid_t vlen_str(void) {
  hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return t;
}

int h5_attr_string(hid_t loc, const char *name, const char *s) {
  hid_t t = vlen_str();
  int rc = attr(loc, name, t, &s);
  H5Tclose(t);
  return rc;
}

/* A dimensionless model's file (set once, before the scenes write): the rolling ball's units that
 * the scenes name become what they are for it (h5_units). */
static int dimensionless = 0;
void h5_set_dimensionless(int on) { dimensionless = on; }

const char *h5_units(const char *units) { return tubes_units_as(units, dimensionless); }

/* A dataset of the given memory type (native double or int), with its units attribute: units, or
 * with units NULL its row of the units table (tubes_units_of; a dataset without a row has none). */
static int write_data(hid_t loc, const char *name, hid_t type, int rank, const hsize_t *dims, const void *data,
                      const char *units) {
  if (!units) {
    char group[256];
    ssize_t n = H5Iget_name(loc, group, sizeof group);
    if (n > 0 && (size_t)n < sizeof group) units = tubes_units_of(group, name);
  }
  hid_t sp = H5Screate_simple(rank, dims, NULL);
  hid_t d = H5Dcreate2(loc, name, type, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  int rc = (d < 0 || H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) ? -1 : 0;
  if (rc == 0 && units) rc = h5_attr_string(d, "units", h5_units(units));
  if (d >= 0) H5Dclose(d);
  H5Sclose(sp);
  return failed(rc);
}

int h5_write_double(hid_t loc, const char *name, int rank, const hsize_t *dims, const double *data,
                    const char *units) {
  return write_data(loc, name, H5T_NATIVE_DOUBLE, rank, dims, data, units);
}

int h5_write_int(hid_t loc, const char *name, hsize_t n, const int *data, const char *units) {
  return h5_write_int_nd(loc, name, 1, &n, data, units);
}

int h5_write_int_nd(hid_t loc, const char *name, int rank, const hsize_t *dims, const int *data, const char *units) {
  return write_data(loc, name, H5T_NATIVE_INT, rank, dims, data, units);
}

int h5_write_strings(hid_t loc, const char *name, hsize_t n, const char *const *s) {
  hid_t t = vlen_str();
  hid_t sp = H5Screate_simple(1, &n, NULL);
  hid_t d = H5Dcreate2(loc, name, t, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  int rc = (d < 0 || H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, s) < 0) ? -1 : 0;
  if (d >= 0) H5Dclose(d);
  H5Sclose(sp);
  H5Tclose(t);
  return failed(rc);
}
