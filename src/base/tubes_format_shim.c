/* A number as C's printf writes it ("%.6g" and the like), for messages written in Fortran (the
 * verdicts of src/workflow/tubes_verdicts.f90) that must read as the program's other messages:
 * Fortran's G format writes 1e-06 as 0.100000E-05. tubes_cstrings' num() calls it. */
#include <stdio.h>
#include <string.h>

/* v by the conversion spec (digits, at most one '.', then one of g, f, e: ".6g", "g", ".1f") into
 * out (len bytes, NUL-terminated); an unknown spec writes "%g". */
void tubes_format_real(double v, const char *spec, char *out, int len) {
  char fmt[16] = "%g";
  size_t n = strlen(spec);
  if (n > 0 && n < 8 && strspn(spec, "0123456789.") == n - 1 && strchr("gfe", spec[n - 1]))
    snprintf(fmt, sizeof fmt, "%%%s", spec);
  if (len > 0) snprintf(out, (size_t)len, fmt, v);
}
