/* libFuzzer target: the whole reading of an input file (nml_load: the C lexer, Fortran's namelist
 * READ, the validator) on arbitrary bytes, under AddressSanitizer and UBSan.
 *
 * Besides "no crash, no hang, no leak", one property: an input that loads is printed as the
 * effective namelist (what `tubes --check` prints and every output file stores), and that text
 * loads again to the same effective namelist. A violation aborts, so libFuzzer keeps the input.
 *
 * Built and run by `make fuzz` (docs/development.md); the seed corpus is tests/fuzz/corpus. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "tubes_input.h"

static char g_in[64], g_again[64];
static FILE *g_null;

static void write_file(const char *path, const uint8_t *data, size_t size) {
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(data, 1, size, f) != size || fclose(f)) {
    perror(path);
    abort();
  }
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
  (void)argc;
  (void)argv;
  const char *dir = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
  snprintf(g_in, sizeof g_in, "%.40s/tubes-fuzz-%d.nml", dir, (int)getpid());
  snprintf(g_again, sizeof g_again, "%.40s/tubes-fuzz-%d.2.nml", dir, (int)getpid());
  g_null = fopen("/dev/null", "w");
  if (!g_null) abort();
  /* a formula's model would run SymPy and the compiler on every mutation: the reader refuses it
   * with a message instead (src/io/tubes_expr.c), and the formulas have tests of their own */
  setenv("TUBES_NO_CODEGEN", "1", 1);
  setenv("TUBES_CACHE_DIR", "/nonexistent/tubes-fuzz-cache", 1);
  return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static tubes_config_t cfg, cfg2;
  static nml_where w, w2;
  static char text[65536], text2[65536];
  write_file(g_in, data, size);
  if (nml_load(g_in, NULL, &cfg, &w, g_null) != 0) return 0;
  if (tubes_nml_write(&cfg, text, (int)sizeof text) < 0) {
    fprintf(stderr, "fuzz: a valid input's effective namelist does not fit %zu bytes\n", sizeof text);
    abort();
  }
  write_file(g_again, (const uint8_t *)text, strlen(text));
  if (nml_load(g_again, NULL, &cfg2, &w2, stderr) != 0) {
    fprintf(stderr, "fuzz: the effective namelist of a valid input is refused:\n%s", text);
    abort();
  }
  if (tubes_nml_write(&cfg2, text2, (int)sizeof text2) < 0 || strcmp(text, text2) != 0) {
    fprintf(stderr, "fuzz: the effective namelist does not reload to itself:\n%s\n---\n%s", text, text2);
    abort();
  }
  return 0;
}
