/* Input handling of the tubes program (src/io/tubes_input.c): the table of namelist
 * variables, a lexer that gives every assignment its line, and validation with messages. */
#ifndef TUBES_INPUT_H
#define TUBES_INPUT_H
#include <stdio.h>
#include "tubes_config.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum { NML_REAL, NML_INT, NML_LOGICAL, NML_STRING } nml_type;

/* One namelist variable: the single source for the lexer, --help and docs/input.md. */
typedef struct {
  const char *group, *name;
  nml_type type;
  int count;            /* array length (1 = scalar) */
  const char *units, *deflt, *allowed, *doc;
} nml_var;

extern const nml_var tubes_nml_vars[];
extern const int tubes_nml_nvars;
extern const char *const tubes_nml_groups[];   /* in tubes_nml_read's order */
extern const int tubes_nml_ngroups;
extern const char *const tubes_scene_names[];
extern const char *const tubes_scene_docs[];
extern const int tubes_nscenes;

/* Where each variable was set in the file (0 = not set). */
typedef struct {
  int group_line[16];               /* line of &group, 0 if absent */
  int var_line[192];               /* per tubes_nml_vars entry */
  char var_text[192][96];          /* first characters of the value as written */
  int var_last[192];               /* arrays: the last element given a value (1-based; nulls are not) */
  int var_nonzero[192];            /* real arrays: the last element given a value other than 0 ... */
  double var_nonzero_value[192];   /* ... and that value */
} nml_where;

/* Lex the file: unknown groups or variables, unterminated groups, malformed values.
 * Returns 0, or 1 after printing a message naming the file and line to err. */
int nml_lex(const char *path, nml_where *w, FILE *err);

/* Turn a failure of tubes_nml_read into a message with the line (best effort). */
void nml_report_read_error(const char *path, const nml_where *w, int group, const char *msg,
                           FILE *err);

/* The line where group.name was set in the file (0: not set). */
int nml_line(const nml_where *w, const char *group, const char *name);

/* Range and consistency checks. Returns the number of errors printed to err. */
int nml_validate(const char *path, const tubes_config_t *cfg, const nml_where *w, FILE *err);

/* The whole reading of an input file: lex, Fortran's namelist READ, the -o override (NULL: none),
 * validation. Returns 0, or 1 after printing every message to err. The driver and the namelist
 * fuzzer (tests/fuzz/) call this one function. */
int nml_load(const char *path, const char *out_override, tubes_config_t *cfg, nml_where *w,
             FILE *err);

/* nml_load for callers without a FILE (the f2py layer): the messages, one per line, go to msg.
 * Returns 0 or 1 (refused), -1 if no memory stream could be opened. */
int tubes_input_check(const char *path, tubes_config_t *cfg, char *msg, int msglen);

/* TUBES_METHOD_* code of a method name, 0 if unknown. */
int tubes_method_code(const char *name);

/* Are these units the rolling ball's, written with cm and s ("cm, cm/s", "(cm/s)^2", "1/s")? (A
 * dimensionless model's file and messages name them "1": h5_units, the reader's model_units.) */
int tubes_units_dimensioned(const char *units);

/* Print the groups, variables and scenes (for --help). */
void nml_print_help(FILE *out);

/* A registered number's range (src/workflow/tubes_config.f90's annotations): 1 with its bounds, whether
 * they are open, whether it is an integer and its allowed text (len bytes); 0 if not registered. */
int tubes_registry_range(const char *group, const char *name, double *lo, double *hi, int *lo_open, int *hi_open,
                         int *is_int, char *allowed, int len);

#ifdef __cplusplus
}
#endif
#endif
