/* A scene's result record (include/tubes.h, "Scenes and their records"; the record is filled by
 * the scene's Fortran procedure, src/workflow/tubes_record.f90): its console lines printed in
 * order, its datasets and attributes written into the output file, its exit code returned. The
 * one writer of every scene that returns a record. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <hdf5.h>
#include "tubes.h"
#include "tubes_h5.h"
#include "tubes_scenes.h"
#include "tubes_record.h"

/* The group at path (slash-separated, under loc), made where it does not exist yet. */
static hid_t group_at(hid_t loc, const char *path) {
  char part[256];
  hid_t g = H5Gopen2(loc, "/", H5P_DEFAULT);
  const char *p = path;
  while (g >= 0 && *p) {
    size_t n = strcspn(p, "/");
    if (n >= sizeof part) { H5Gclose(g); return -1; }
    memcpy(part, p, n);
    part[n] = 0;
    hid_t next = H5Lexists(g, part, H5P_DEFAULT) > 0 ? H5Gopen2(g, part, H5P_DEFAULT) : h5_group(g, part);
    H5Gclose(g);
    g = next;
    p += n;
    if (*p == '/') p++;
  }
  return g;
}

/* Item k of record h into file. Returns 0, or nonzero on a write failure. */
static int write_item(hid_t file, int h, int k) {
  char group[256], name[64], units[32];
  int kind, rank, slen;
  long long dims[5];
  int n = tubes_record_item(h, k, &kind, group, name, units, &rank, dims, &slen);
  if (n < 0) return 1;
  hid_t g = group_at(file, group);
  if (g < 0) return 1;
  int rc = 0;
  const char *u = units[0] ? units : NULL;
  hsize_t hd[5];
  for (int i = 0; i < rank && i < 5; i++) hd[i] = (hsize_t)dims[i];
  switch (kind) {
  case TUBES_REC_REAL: {
    double *v = malloc(sizeof(double) * (n ? n : 1));
    if (!v) { rc = 1; break; }
    tubes_record_reals(h, k, n, v);
    rc = h5_write_double(g, name, rank, hd, v, u);
    free(v);
    break;
  }
  case TUBES_REC_INT: {
    int *v = malloc(sizeof(int) * (n ? n : 1));
    if (!v) { rc = 1; break; }
    tubes_record_ints(h, k, n, v);
    rc = rank == 1 ? h5_write_int(g, name, hd[0], v, u) : h5_write_int_nd(g, name, rank, hd, v, u);
    free(v);
    break;
  }
  case TUBES_REC_STRINGS: {
    int len = slen + 1;
    char *buf = malloc((size_t)len * (n ? n : 1));
    const char **s = malloc(sizeof(char *) * (n ? n : 1));
    if (!buf || !s) { free(buf); free(s); rc = 1; break; }
    for (int j = 0; j < n; j++) {
      tubes_record_string(h, k, j + 1, buf + (size_t)len * j, len);
      s[j] = buf + (size_t)len * j;
    }
    rc = h5_write_strings(g, name, (hsize_t)n, (const char *const *)s);
    free(buf);
    free(s);
    break;
  }
  case TUBES_REC_ATTR_REAL: {
    double v;
    tubes_record_reals(h, k, 1, &v);
    rc = h5_attr_double(g, name, v);
    break;
  }
  case TUBES_REC_ATTR_INT:
    rc = h5_attr_long(g, name, tubes_record_long(h, k));
    break;
  case TUBES_REC_ATTR_STRING: {
    char *buf = malloc((size_t)slen + 1);
    if (!buf) { rc = 1; break; }
    tubes_record_string(h, k, 1, buf, slen + 1);
    rc = h5_attr_string(g, name, buf);
    free(buf);
    break;
  }
  default:
    rc = 1;
  }
  H5Gclose(g);
  return rc;
}

int record_emit(hid_t file, int h) {
  int ni = 0, nl = 0;
  tubes_record_sizes(h, &ni, &nl);
  char small[1024];
  for (int j = 1; j <= nl; j++) {
    int stream = 0, n = tubes_record_line(h, j, &stream, small, (int)sizeof small);
    char *text = small, *big = NULL;
    if (n >= (int)sizeof small && (big = malloc((size_t)n + 1))) {
      tubes_record_line(h, j, &stream, big, n + 1);
      text = big;
    }
    if (stream == 2)
      fprintf(stderr, "%s\n", text);
    else
      printf("%s\n", text);
    free(big);
  }
  int rc = 0;
  for (int k = 1; k <= ni && !rc; k++) rc = write_item(file, h, k);
  int code = tubes_record_code(h);
  tubes_record_free(h);
  if (rc) return EXIT_IO;
  return code < 0 ? EXIT_IO : code;
}
