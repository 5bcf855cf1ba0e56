/* Namelist input: variable table, lexer with line numbers, validation (include/tubes_input.h).
 * Fortran's namelist READ (src/io/tubes_nml.f90) reads the values; this file makes sure every
 * mistake is reported with the file, group, variable and line before and after it does. */
#include "tubes_input.h"
#include "tubes_registry.h"
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <unistd.h>

const char *const tubes_nml_groups[] = {"run", "model", "equilibria", "trajectory", "integrator",
                                        "orbits", "section", "tubes", "transition", "montecarlo",
                                        "sections", "experiment", "flux", "scan"};
const int tubes_nml_ngroups = 14;

const char *const tubes_scene_names[] = {"equilibria", "trajectory", "orbits", "tubes", "transition",
                                         "montecarlo", "sections", "synthetic_experiment", "flux", "scan"};
const char *const tubes_scene_docs[] = {
    "critical points of H, Morse index, names, saddle linearization (lambda, omega, T_po)",
    "one trajectory with sampled output and its energy error",
    "Lyapunov orbits of a saddle at the requested dE: period, action, Floquet multipliers, "
    "continuation and the end of the family",
    "tube cuts: the orbits' stable (or unstable) manifolds on the section, their areas (Green), "
    "the eps/10 check, and the energy surface on the section (A0, tau)",
    "p_trans(dE) = A_tube / A_E on a grid of dE, beside the leading-order formula",
    "Monte Carlo check: points uniform on the section's energy surface, integrated and classified",
    "Poincare maps of the section at fixed dE (KAM tori, chaos, the tube)",
    "synthetic tracking data like the paper's experiment: balls released from rest, filmed with "
    "noise and pixel rounding (docs/experiment-data.md)",
    "the flux of trajectories through the saddle's bottleneck in N degrees of freedom: sampled on the "
    "dividing surface, beside the leading-order formula (docs/theory.md)",
    "continuation in a model parameter or a formula's constant (&scan): equilibria, the saddle's data, "
    "its orbits and p_trans followed, folds located (docs/scan.md)"};
const int tubes_nscenes = 10;

const nml_var tubes_nml_vars[] = {
    {"run", "scenes", NML_STRING, TUBES_NSCENES, "-", "'equilibria'",
     "the scenes of tubes_scene_names (allowed_text lists them)", "scenes to run, in order"},
    {"run", "output", NML_STRING, 1, "-", "'tubes.h5'", "a writable path",
     "HDF5 output file (overridden by -o)"},
    {"model", "system", NML_STRING, 1, "-", "'rolling_ball'",
     "rolling_ball, henon_heiles, de_leon_berne, coupled_quartic, cr3bp",
     "the Hamiltonian system (docs/models.md); its parameters follow"},
    {"model", "alpha", NML_REAL, 1, "1/cm", "0.07", "> 0",
     "rolling_ball: bowl curvature of H; coupled_quartic (default 1): negative curvature of x"},
    {"model", "beta", NML_REAL, 1, "1", "1.017", ">= 0",
     "rolling_ball: well depth coefficient of H; coupled_quartic (default 1, > 0): quartic stiffness"},
    {"model", "gamma", NML_REAL, 1, "cm^2", "15.103", "> 0", "rolling_ball: smoothing of H's ridges"},
    {"model", "xi", NML_REAL, 1, "1/cm", "0.00656", "finite", "rolling_ball: x-y coupling (tilt) of H"},
    {"model", "h0", NML_REAL, 1, "cm", "12.065", "finite", "rolling_ball: height offset of H"},
    {"model", "g", NML_REAL, 1, "cm/s^2", "981", "> 0", "rolling_ball: gravitational acceleration"},
    {"model", "damping_ratio", NML_REAL, 1, "1", "0", "0 <= zeta < 1",
     "natural models: viscous damping ratio zeta of the lowest well's slow mode (0 = conservative)"},
    {"model", "rolling_resistance", NML_REAL, 1, "1", "0", "0 <= C_rr < 1",
     "a ball (rolling_ball, a formula's surface): rolling resistance C_rr, a drag C_rr g opposing the velocity"},
    {"model", "noise", NML_REAL, 1, "(cm/s)^2/s", "0", ">= 0; not with temperature",
     "natural models: white noise D on the momenta, dp = ... + sqrt(2 D) dW (the ball's units; 0 = none)"},
    {"model", "temperature", NML_REAL, 1, "(cm/s)^2", "0", ">= 0; needs damping_ratio > 0",
     "natural models: noise by fluctuation-dissipation, covariance 2 c theta A^-1 (the ball's units; 0 = none)"},
    {"model", "m_a", NML_REAL, 1, "1", "8 (de_leon_berne), 1 (coupled_quartic)", "> 0",
     "de_leon_berne, coupled_quartic: mass of the x mode"},
    {"model", "m_b", NML_REAL, 1, "1", "8 (de_leon_berne), 1 (coupled_quartic)", "> 0",
     "de_leon_berne, coupled_quartic: mass of the y mode"},
    {"model", "d", NML_REAL, 1, "1", "10", "finite", "de_leon_berne: dissociation energy D of the Morse oscillator"},
    {"model", "lambda", NML_REAL, 1, "1", "1.5", "> 0", "de_leon_berne: range of the Morse oscillator"},
    {"model", "zeta", NML_REAL, 1, "1", "1", "finite", "de_leon_berne: decay of the double well along x"},
    {"model", "eps_s", NML_REAL, 1, "1", "1", "finite", "de_leon_berne: energy of the saddle"},
    {"model", "omega", NML_REAL, 1, "1", "1", "finite", "coupled_quartic: stiffness of the y mode"},
    {"model", "eps", NML_REAL, 1, "1", "0.1", "finite", "coupled_quartic: coupling of x and y"},
    {"model", "mu", NML_REAL, 1, "1", "0.01215058560962404", "0 < mu <= 0.5",
     "cr3bp: mass ratio m2/(m1 + m2) (Earth-Moon by default)"},
    {"model", "spatial", NML_LOGICAL, 1, "-", ".false.", ".true., .false. (cr3bp only)",
     "cr3bp: the spatial problem, 3 degrees of freedom (the library's cr3bp_spatial)"},
    {"model", "hamiltonian", NML_STRING, 1, "energy", "-", "a formula (docs/models.md)",
     "expression: H(q, p) in the coordinates, momenta and constants; ^ or ** for powers"},
    {"model", "coordinates", NML_STRING, TUBES_MAXDOF, "-", "'x', 'y'", "1 to 3 distinct names",
     "expression: the names of q_1..q_N"},
    {"model", "momenta", NML_STRING, TUBES_MAXDOF, "-", "'p' + each coordinate", "one name per coordinate",
     "expression: the names of p_1..p_N, in the coordinates' order"},
    {"model", "constants", NML_STRING, TUBES_MAXCONST, "-", "none", "'name = value'",
     "expression, or surface = 'expression': named constants; a value may use the constants before it"},
    {"model", "dissipation", NML_STRING, 1, "-", "'' (the coefficients' laws)",
     "none, or viscous, rolling, noise joined by + (viscous+rolling)",
     "the dissipation laws the model follows, a check of its coefficients: each law named needs its coefficient "
     "(damping_ratio; rolling_resistance; noise or temperature) > 0, each coefficient > 0 its law named"},
    {"model", "surface", NML_STRING, 1, "-", "'fourwell'", "fourwell, expression",
     "rolling_ball: the surface: the paper's four-well (alpha..h0), or the formula height"},
    {"model", "height", NML_STRING, 1, "cm", "-", "a formula in x, y [cm]",
     "rolling_ball with surface = 'expression': z = h(x, y), with the constants"},
    {"equilibria", "box", NML_REAL, TUBES_MAXDOF, "units of q", "the system's (20 cm for the ball)", "> 0",
     "half-widths of the search box per coordinate (one value: every coordinate)"},
    {"equilibria", "box_center", NML_REAL, TUBES_MAXDOF, "units of q", "the system's (0)", "finite",
     "centre of the search box"},
    TUBES_REGISTRY_ROWS_EQUILIBRIA   /* n_grid */
    {"equilibria", "saddle", NML_STRING, 1, "-", "'' (the &orbits choice)", "a rank-1 saddle's name",
     "the rank-1 saddle the equilibria scene reports in /saddle"},
    TUBES_REGISTRY_ROWS_TRAJECTORY   /* every variable (registered: src/workflow/tubes_config.f90) */
    TUBES_REGISTRY_ROWS_INTEGRATOR   /* every variable */
    {"orbits", "saddle", NML_STRING, 1, "-", "the system's (S12 for the ball, L1 for cr3bp)",
     "the name of a rank-1 saddle of the model (docs/models.md)",
     "the rank-1 saddle of every scene that needs one"},
    {"orbits", "saddle_near", NML_REAL, TUBES_MAXDOF, "units of q", "the system's (henon_heiles: 0, 1)",
     "finite; not with saddle", "choose the rank-1 saddle nearest this configuration point instead"},
    {"orbits", "de", NML_REAL, TUBES_MAXDE, "(cm/s)^2", TUBES_REGISTRY_DEFAULT_ORBITS_DE, "> 0, increasing (with guess: any sign)",
     "excess energies dE = E - E_e of the orbits"},
    TUBES_REGISTRY_ROWS_ORBITS   /* method .. n_samples */
    {"orbits", "family", NML_INT, 1, "-", "1",
     "1 .. N-1, 'lyapunov', 'vertical', 'halo_north', 'halo_south', 'axial', 'branch:K'",
     "the Lyapunov family of the saddle's k-th centre frequency (ascending; N = 3: 2 families), the planar "
     "('lyapunov'; N < 3: family 1) or out-of-plane ('vertical') one, the halo branch off family N-1, the "
     "axial branch off the planar family, or the family from the K-th bifurcation of the guess's family (else "
     "family 1)"},
    {"orbits", "guess", NML_REAL, 64, "state units", "none", "exactly 2N finite values",
     "a state on (or near) a periodic orbit: the family through it (docs/orbits.md, Orbits from a guess)"},
    {"orbits", "period", NML_REAL, 1, "s", "none", "> 0 (with guess only)", "the guess's period"},
    {"orbits", "jacobi", NML_REAL, TUBES_MAXDE, "1", "none", "finite, strictly decreasing (the energies "
     "increasing); a model with a Jacobi constant (cr3bp); not with de or periods",
     "the orbits at these Jacobi constants C = -2 H instead of de (docs/orbits.md, Orbits by Jacobi constant or period)"},
    {"orbits", "periods", NML_REAL, TUBES_MAXDE, "time", "none", "> 0, in the order the family reaches them; "
     "any family but 'branch:K'; not with de or jacobi",
     "the orbits with these periods instead of de (the crossing nearest the family's start; docs/orbits.md)"},
    {"section", "kind", NML_STRING, 1, "-", "the system's ('ray' for the ball)", "ray, plane",
     "ray: the ball's polar ray theta = angle; plane: q_index = value (docs/tubes.md, Sections)"},
    {"section", "angle", NML_REAL, 1, "deg", "45", "-360 .. 360", "kind = 'ray': the ray theta = angle (U1: 45)"},
    {"section", "p_theta_sign", NML_INT, 1, "-", "1", "-1, 1",
     "kind = 'ray': branch: +1 p_theta > 0 (U1^-), -1 p_theta < 0 (U1^+)"},
    {"section", "index", NML_INT, 1, "-", "the system's", "1 .. N",
     "kind = 'plane': the coordinate k of the plane q_k = value"},
    {"section", "value", NML_REAL, 1, "units of q", "the system's", "finite", "kind = 'plane': the level c of q_k = c"},
    {"section", "direction", NML_INT, 1, "-", "the system's", "-1, 1",
     "kind = 'plane': the sign of dq_k/dt at the crossings"},
    TUBES_REGISTRY_ROWS_TUBES   /* every variable */
    TUBES_REGISTRY_ROWS_TRANSITION   /* every variable */
    TUBES_REGISTRY_ROWS_MONTECARLO   /* de .. t_max */
    {"montecarlo", "gate", NML_REAL, 1, "units of q", "the system's (1.5 cm for the ball)", "> 0",
     "a point has transited when it is this far past the saddle along its reaction coordinate"},
    TUBES_REGISTRY_ROWS_MONTECARLO_2   /* area_tol */
    TUBES_REGISTRY_ROWS_SECTIONS   /* every variable */
    TUBES_REGISTRY_ROWS_EXPERIMENT   /* n_tracks .. seed */
    {"experiment", "csv", NML_STRING, 1, "-", "''", "a writable path or ''",
     "also write the tracks as CSV (track,t,x,y) to this file; '' = no CSV"},
    TUBES_REGISTRY_ROWS_FLUX   /* de, n_samples, seed, t_max */
    {"flux", "gate", NML_REAL, 1, "units of q", "the &montecarlo gate", "> 0",
     "half-width of the slab around the dividing surface that a passage crosses"},
    TUBES_REGISTRY_ROWS_FLUX_2   /* tol .. cut_eps */
    {"scan", "parameter", NML_STRING, 1, "-", "- (required)",
     "a parameter of the system (&model), not a dissipation one; not a formula's constant",
     "the model parameter the scan scene moves (docs/scan.md)"},
    {"scan", "to", NML_REAL, 1, "the parameter's", "- (required)", "finite, not the start value; the model's range",
     "the parameter's end value (the start: its &model value)"},
    TUBES_REGISTRY_ROWS_SCAN   /* n */
    {"scan", "de", NML_REAL, TUBES_MAXDE, "energy", "&orbits de if set there, else none", "> 0, increasing",
     "excess energies of the saddle's Lyapunov orbits followed along the scan (none: no orbits)"},
    TUBES_REGISTRY_ROWS_SCAN_2   /* p_trans */
};
const int tubes_nml_nvars = (int)(sizeof tubes_nml_vars / sizeof tubes_nml_vars[0]);
_Static_assert(sizeof tubes_nml_vars / sizeof tubes_nml_vars[0] <= 192, "nml_where holds 192 variables");

/* The registered strings and their values (the annotations' allowed text, ", " between them). */
static const struct {
  const char *group, *name;
  size_t offset;
  const char *values;
} reg_str[] = {TUBES_REGISTRY_STRINGS};

/* The position (1-based) of v among the values of the registered string &group name; 0: not one. */
static int registered_value(const char *group, const char *name, const char *v) {
  for (int k = 0; k < TUBES_REGISTRY_NS; k++) {
    if (strcmp(reg_str[k].group, group) || strcmp(reg_str[k].name, name)) continue;
    const char *p = reg_str[k].values;
    size_t lv = strlen(v);
    for (int i = 1; *p; i++) {
      size_t l = strcspn(p, ",");
      if (l == lv && !strncmp(p, v, l)) return i;
      p += l;
      p += strspn(p, ", ");
    }
    return 0;
  }
  return 0;
}

/* A method's code: its place in &integrator method's list of values (src/workflow/tubes_config.f90's
 * annotation, the one list of the names), = TUBES_METHOD_* (include/tubes.h; tests/test_registry.py
 * checks the two agree); 0: no method of that name. */
int tubes_method_code(const char *name) { return registered_value("integrator", "method", name); }

static int group_index(const char *g) {
  for (int i = 0; i < tubes_nml_ngroups; i++)
    if (strcasecmp(g, tubes_nml_groups[i]) == 0) return i;
  return -1;
}
static int var_index(const char *g, const char *name) {
  for (int i = 0; i < tubes_nml_nvars; i++)
    if (strcasecmp(g, tubes_nml_vars[i].group) == 0 && strcasecmp(name, tubes_nml_vars[i].name) == 0)
      return i;
  return -1;
}
static void list_vars(const char *g, FILE *err) {
  const char *sep = "";
  for (int i = 0; i < tubes_nml_nvars; i++)
    if (strcasecmp(g, tubes_nml_vars[i].group) == 0) {
      fprintf(err, "%s%s", sep, tubes_nml_vars[i].name);
      sep = ", ";
    }
}
static void list_groups(FILE *err) {
  for (int i = 0; i < tubes_nml_ngroups; i++) fprintf(err, "%s&%s", i ? ", " : "", tubes_nml_groups[i]);
}

static char *slurp(const char *path, size_t *len, FILE *err) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(err, "tubes: cannot open input file '%s': %s\n", path, strerror(errno));
    return NULL;
  }
  size_t cap = 4096, n = 0;
  char *buf = malloc(cap);
  size_t r;
  while (buf && (r = fread(buf + n, 1, cap - n - 1, f)) > 0) {
    n += r;
    if (n > TUBES_MAX_INPUT) {   /* a namelist is a few kB; /dev/zero or a wrong file is not one */
      fprintf(err, "tubes: input file '%s' is larger than %d bytes (the limit): a namelist is text of a few "
              "kilobytes; is it the right file?\n", path, TUBES_MAX_INPUT);
      free(buf);
      fclose(f);
      return NULL;
    }
    if (n + 1 >= cap) {
      char *nb = realloc(buf, cap *= 2);
      if (!nb) {
        fprintf(err, "tubes: cannot read input file '%s': %s\n", path, strerror(errno));
        free(buf);
        buf = NULL;
      }
      else buf = nb;
    }
  }
  if (ferror(f)) {
    fprintf(err, "tubes: cannot read input file '%s': %s\n", path, strerror(errno));
    free(buf);
    buf = NULL;
  }
  fclose(f);
  if (buf) buf[n] = '\0';
  *len = n;
  return buf;
}

/* Check one value token against the variable's type (and an integer against the range of the
 * variable's C type: Fortran's READ would only say "Integer overflow while reading item 1").
 * Returns NULL if fine, else a reason (in why, for a reason with numbers). */
static const char *check_token(const nml_var *var, const char *tok, size_t len, char *why, size_t whylen) {
  nml_type t = var->type;
  char tmp[256];
  if (len >= sizeof tmp) len = sizeof tmp - 1;
  memcpy(tmp, tok, len);
  tmp[len] = '\0';
  const char *v = tmp;                       /* the lexer has taken off a repeat count */
  switch (t) {
  case NML_REAL: {
    /* Fortran's form only: [sign] digits [. digits] [e|d [sign] digits]. strtod alone would take
     * C's hex (0x1p-4), which Fortran's READ does not read: before a '/' it kept the default. */
    const char *q = v + (*v == '+' || *v == '-');
    int mant = 0;
    while (isdigit((unsigned char)*q)) { q++; mant++; }
    if (*q == '.') for (q++; isdigit((unsigned char)*q); q++) mant++;
    if (mant && strchr("eEdD", *q) && *q) {
      q++;
      q += *q == '+' || *q == '-';
      if (!isdigit((unsigned char)*q)) return "is not a real number (Fortran's form: 1.5, -2, 3e-4 or 3d-4)";
      while (isdigit((unsigned char)*q)) q++;
    }
    if (!mant || *q) {
      if (!strncasecmp(v + (*v == '+' || *v == '-'), "inf", 3) || !strncasecmp(v + (*v == '+' || *v == '-'), "nan", 3))
        return "is not a finite real number";
      return "is not a real number (Fortran's form: 1.5, -2, 3e-4 or 3d-4)";
    }
    char num[256];
    size_t k = 0;
    for (const char *p = v; *p && k < sizeof num - 1; p++) num[k++] = (*p == 'd' || *p == 'D') ? 'e' : *p;
    num[k] = '\0';
    char *end;
    errno = 0;
    double x = strtod(num, &end);
    if (end == num || *end != '\0') return "is not a real number";
    if (!isfinite(x) || errno == ERANGE) return "is not a finite real number";
    return NULL;
  }
  case NML_INT: {
    char *end;
    /* &orbits family also takes a branch's name (docs/orbits.md, "Branch switching") */
    if (!strcmp(var->name, "family") && (v[0] == '\'' || v[0] == '"')) return NULL;
    errno = 0;
    long long x = strtoll(v, &end, 10);
    if (end == v || *end != '\0') return "is not an integer";
    /* max_steps is a 64-bit integer (int64_t), every other integer a C int */
    long long lo = strcmp(var->name, "max_steps") ? INT_MIN : LLONG_MIN;
    long long hi = strcmp(var->name, "max_steps") ? INT_MAX : LLONG_MAX;
    if (errno == ERANGE || x < lo || x > hi) {
      snprintf(why, whylen, "is out of range: allowed %s, and an integer of '%s' lies in %lld .. %lld",
               var->allowed, var->name, lo, hi);
      return why;
    }
    return NULL;
  }
  case NML_LOGICAL: {
    const char *ok[] = {".true.", ".false.", "t", "f", ".t.", ".f.", "true", "false"};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
      if (strcasecmp(v, ok[i]) == 0) return NULL;
    return "is not a logical (.true. or .false.)";
  }
  case NML_STRING:
    if (v[0] == '\'' || v[0] == '"') return NULL;   /* its length: string_cap */
    return "is not a quoted string (write it as 'text')";
  }
  return NULL;
}

/* The most characters a string variable holds (Fortran's READ would cut a longer one short). */
static int string_cap(const nml_var *v) {
  if (!strcmp(v->name, "hamiltonian") || !strcmp(v->name, "height")) return TUBES_LEXPR - 1;
  if (!strcmp(v->name, "coordinates") || !strcmp(v->name, "momenta")) return TUBES_LSYM - 1;
  if (!strcmp(v->name, "constants")) return TUBES_LCONST - 1;
  if (!strcmp(v->name, "output") || !strcmp(v->name, "csv")) return TUBES_LPATH - 1;
  if (!strcmp(v->name, "saddle")) return TUBES_LSADDLE - 1;
  return TUBES_LNAME - 1;
}

int nml_lex(const char *path, nml_where *w, FILE *err) {
  memset(w, 0, sizeof *w);
  size_t len = 0;
  char *s = slurp(path, &len, err);
  if (!s) return 1;
  int line = 1, cur = -1, cur_line = 0, rc = 0;
  /* a control byte (NUL ends the lexer's string while Fortran's READ goes on past it): not text */
  for (size_t i = 0; i < len; i++) {
    unsigned char ch = (unsigned char)s[i];
    if (ch == '\n') line++;
    else if (ch < 32 && ch != '\t' && ch != '\r') {
      fprintf(err, "%s:%d: byte 0x%02x is not text: the input holds printable characters, tabs and "
              "line ends only\n", path, line, ch);
      free(s);
      return 1;
    }
  }
  line = 1;
  char *p = s;
  const char *gname = NULL;
#define FAIL(...) do { fprintf(err, "%s:%d: ", path, line); fprintf(err, __VA_ARGS__); \
                       fputc('\n', err); rc = 1; goto done; } while (0)
  while (*p) {
    if (*p == '\n') { line++; p++; continue; }
    if (isspace((unsigned char)*p) || (cur >= 0 && *p == ',')) { p++; continue; }
    if (*p == '!') { while (*p && *p != '\n') p++; continue; }
    if (cur < 0) {                                   /* outside any group */
      if (*p != '&' && *p != '$')
        FAIL("text outside a namelist group (a group starts with &name and ends with /; "
             "comments start with !)");
      p++;
      char name[64];
      int k = 0;
      while ((isalnum((unsigned char)*p) || *p == '_') && k < 63) name[k++] = *p++;
      name[k] = '\0';
      if (k == 0) FAIL("'&' must be followed by a group name");
      int gi = group_index(name);
      if (gi < 0) {
        fprintf(err, "%s:%d: unknown namelist group &%s; known groups: ", path, line, name);
        list_groups(err);
        fputc('\n', err);
        rc = 1;
        goto done;
      }
      if (w->group_line[gi])
        FAIL("group &%s appears twice (first at line %d); merge them", name, w->group_line[gi]);
      w->group_line[gi] = line;
      cur = gi;
      cur_line = line;
      gname = tubes_nml_groups[gi];
      continue;
    }
    /* inside group cur */
    if (*p == '/') { cur = -1; p++; continue; }
    if (*p == '&' || *p == '$') {
      if (strncasecmp(p + 1, "end", 3) == 0 && !isalnum((unsigned char)p[4])) { cur = -1; p += 4; continue; }
      FAIL("group &%s (line %d) is not closed with '/' before the next group", gname, cur_line);
    }
    if (!(isalpha((unsigned char)*p))) FAIL("&%s: expected a variable name, found '%c'", gname, *p);
    char name[64];
    int k = 0;
    while ((isalnum((unsigned char)*p) || *p == '_' || *p == '%') && k < 63) name[k++] = *p++;
    name[k] = '\0';
    int vi = var_index(gname, name);
    if (vi < 0) {
      fprintf(err, "%s:%d: &%s: unknown variable '%s'; variables of &%s: ", path, line, gname, name, gname);
      list_vars(gname, err);
      fputc('\n', err);
      rc = 1;
      goto done;
    }
    const nml_var *v = &tubes_nml_vars[vi];
    while (*p == ' ' || *p == '\t') p++;
    int first_index = 1;
    if (*p == '(') {
      if (v->count == 1) FAIL("&%s: '%s' is a scalar and takes no index", gname, name);
      char *end;
      long ix = strtol(p + 1, &end, 10);
      if (end == p + 1 || *end != ')' || ix < 1 || ix > v->count)
        FAIL("&%s: bad index for '%s' (allowed 1 to %d)", gname, name, v->count);
      first_index = (int)ix;
      p = end + 1;
      while (*p == ' ' || *p == '\t') p++;
    }
    if (*p != '=') FAIL("&%s: expected '=' after '%s'", gname, name);
    p++;
    if (w->var_line[vi] && v->count == 1)
      FAIL("&%s: '%s' is set twice (first at line %d)", gname, name, w->var_line[vi]);
    w->var_line[vi] = line;
    /* values until the next "name =" or "name(" or '/' */
    int nvals = 0, vline = line;
    char *vstart = NULL;
    for (;;) {
      int commas = 0;   /* two commas with only blanks between: a null value (the element is left as it is) */
      while (*p == ' ' || *p == '\t' || *p == ',' || *p == '\n' || *p == '\r' || *p == '!') {
        if (*p == '!') { while (*p && *p != '\n') p++; continue; }
        if (*p == '\n') line++;
        commas += *p == ',';
        p++;
      }
      if (!*p || *p == '/' || *p == '&' || *p == '$') break;
      char *item = p, *tok = p;
      long rep = 1;                                  /* a repeat count: r*value, or r* (r nulls) */
      if (isdigit((unsigned char)*p)) {
        char *q = p;
        while (isdigit((unsigned char)*q)) q++;
        if (*q == '*') {
          errno = 0;
          rep = strtol(p, NULL, 10);
          if (rep < 1 || errno == ERANGE || rep > v->count)
            FAIL("&%s: repeat count %.*s of '%s' is out of range (1 to %d)", gname, (int)(q - p > 20 ? 20 : q - p), p,
                 name, v->count);
          p = tok = q + 1;
        }
      }
      if (tok != item && (!*p || isspace((unsigned char)*p) || *p == ',' || *p == '/')) {
        /* r null values: nothing to check */
      } else if (*p == '\'' || *p == '"') {
        char q = *p++;
        int chars = 0, kept = 0;   /* characters, and up to the last non-blank (Fortran pads) */
        for (;;) {
          if (!*p || *p == '\n') FAIL("&%s: unterminated string in the value of '%s'", gname, name);
          if (*p == q && p[1] == q) { p += 2; kept = ++chars; continue; }
          if (*p == q) { p++; break; }
          chars++;
          if (*p != ' ') kept = chars;
          p++;
        }
        chars = kept;
        if (chars > string_cap(v))
          FAIL("&%s: the value of '%s' is %d characters long: at most %d are allowed", gname, name, chars,
               string_cap(v));
      } else {
        /* is this the next assignment? identifier followed by '=' or '(' */
        char *q = p;
        if (isalpha((unsigned char)*q)) {
          while (isalnum((unsigned char)*q) || *q == '_' || *q == '%') q++;
          char *r = q;
          while (*r == ' ' || *r == '\t') r++;
          if (*r == '=' || (*r == '(' && v->type != NML_STRING)) break;
          if (*r == '(' ) break;
        }
        while (*p && !isspace((unsigned char)*p) && *p != ',' && *p != '/' && *p != '!') p++;
      }
      size_t len = (size_t)(p - tok);
      if (!vstart) {
        vstart = item;
        size_t m = (size_t)(p - item) < 95 ? (size_t)(p - item) : 95;
        memcpy(w->var_text[vi], item, m);
        w->var_text[vi][m] = '\0';
      }
      nvals += vstart == item && nvals == 0 ? commas : (commas > 1 ? commas - 1 : 0);   /* "= , 5": a null first */
      if (len) {   /* elements first_index + nvals .. + rep - 1 are set: the last, and the last not 0 */
        int hi = first_index + nvals + (int)rep - 1;
        if (hi > w->var_last[vi]) w->var_last[vi] = hi;
        if (v->type == NML_REAL && hi > w->var_nonzero[vi]) {
          char num[64];
          size_t m = len < sizeof num - 1 ? len : sizeof num - 1, k;
          for (k = 0; k < m; k++) num[k] = (tok[k] == 'd' || tok[k] == 'D') ? 'e' : tok[k];
          num[m] = '\0';
          double x = strtod(num, NULL);
          if (x != 0) {
            w->var_nonzero[vi] = hi;
            w->var_nonzero_value[vi] = x;
          }
        }
      }
      nvals += (int)rep;
      char whybuf[256];
      const char *why = len ? check_token(v, tok, len, whybuf, sizeof whybuf) : NULL;
      if (why)
        FAIL("&%s: value %.*s of '%s' %s (%s: %s)", gname, (int)(len > 60 ? 60 : len), tok, name,
             why, v->name, v->doc);
      if (first_index - 1 + nvals > v->count)
        FAIL("&%s: too many values for '%s' (at most %d)", gname, name, v->count);
    }
    (void)vline;
    if (nvals == 0) FAIL("&%s: '%s =' has no value", gname, name);
    if (!*p) break;
  }
  if (cur >= 0) {
    fprintf(err, "%s:%d: group &%s is not closed with '/'\n", path, cur_line, gname);
    rc = 1;
  }
done:
#undef FAIL
  free(s);
  return rc;
}

void nml_report_read_error(const char *path, const nml_where *w, int group, const char *msg,
                           FILE *err) {
  const char *g = (group >= 0 && group < tubes_nml_ngroups) ? tubes_nml_groups[group] : "?";
  /* gfortran says "Cannot match namelist object name <token>": find the token's variable */
  const char *tok = strstr(msg, "object name ");
  if (tok) {
    tok += strlen("object name ");
    for (int i = 0; i < tubes_nml_nvars; i++)
      if (strcasecmp(tubes_nml_vars[i].group, g) == 0 && w->var_line[i] &&
          strstr(w->var_text[i], tok)) {
        fprintf(err, "%s:%d: &%s: cannot read the value of '%s' (%s): %s\n", path, w->var_line[i],
                g, tubes_nml_vars[i].name, w->var_text[i], msg);
        return;
      }
  }
  fprintf(err, "%s:%d: &%s: %s\n", path, group >= 0 ? w->group_line[group] : 0, g, msg);
}

static int line_of(const nml_where *w, const char *group, const char *name) {
  int i = var_index(group, name);
  return i >= 0 ? w->var_line[i] : 0;
}
int nml_line(const nml_where *w, const char *group, const char *name) { return line_of(w, group, name); }
/* The line a message points at: the variable's, or its group's when the file does not set it. */
static int line_or_group(const nml_where *w, const char *group, const char *name) {
  int ln = line_of(w, group, name);
  return ln ? ln : w->group_line[group_index(group)];
}

/* The units of the table (the rolling ball's: cm, s, (cm/s)^2, ...; "energy", "time" and "units of q"
 * for any model) as they are for the model of c: the ball's as given, "1" for a dimensionless
 * model (its length units are not cm: tubes_units_dimensioned, h5_units' rule too), and "the model's
 * units" when the model is not known. */
int tubes_units_dimensioned(const char *units) {
  /* cm, s and their products, quotients and powers ("cm, cm/s", "(cm/s)^2", "1/s", ...) */
  return strspn(units, "cms/^()0123456789, -") == strlen(units) && strpbrk(units, "cs");
}

static const char *model_units(const tubes_config_t *c, const char *units) {
  int dimensioned = tubes_units_dimensioned(units);
  int generic = !strcmp(units, "energy") || !strcmp(units, "time") || !strcmp(units, "units of q");
  if (!dimensioned && !generic) return units;
  static char names[TUBES_MAXPARAM * TUBES_LPARAM], punits[TUBES_MAXPARAM * TUBES_LUNITS],
      docs[TUBES_MAXPARAM * TUBES_LDOC];
  char sys[TUBES_LSYSTEM], summary[TUBES_LSUMMARY], lu[8] = "", sad[8], sk[8], surf[TUBES_LSUMMARY];
  double defs[TUBES_MAXPARAM], box[TUBES_MAXDOF], boxc[TUBES_MAXDOF], near[TUBES_MAXDOF], sv, sa, gate;
  int ndof, np, si, sd;
  snprintf(sys, sizeof sys, "%s", c->model);
  if (c->nparams < 0 || tubes_model_info(sys, &ndof, &np, names, defs, punits, docs, summary, lu, box, boxc, sad,
                                         near, sk, &si, &sv, &sd, &sa, &gate, surf) < 0)
    return "the model's units";
  if (strcmp(lu, "cm")) return "1";
  if (!strcmp(units, "energy")) return "(cm/s)^2";
  if (!strcmp(units, "time")) return "s";
  if (!strcmp(units, "units of q")) return "cm";
  return units;
}

/* group.name (element elem of an array, 1-based; 0: the variable) is out of range: the message. */
static int bad_at(const char *path, const tubes_config_t *c, const nml_where *w, const char *group,
                  const char *name, int elem, FILE *err, const char *fmt, double value) {
  int i = var_index(group, name);
  int ln = line_or_group(w, group, name);
  /* the value as the user wrote it when it was set in the file (1e-16, not 9.9999999999999998e-17) */
  char shown[112], named[48];
  if (i >= 0 && w->var_line[i] && tubes_nml_vars[i].count == 1 && w->var_text[i][0])
    snprintf(shown, sizeof shown, "%s", w->var_text[i]);
  else
    snprintf(shown, sizeof shown, "%.17g", value);
  if (elem > 0) snprintf(named, sizeof named, "%s(%d)", name, elem);
  else snprintf(named, sizeof named, "%s", name);
  fprintf(err, "%s:%d: &%s: %s = %s is out of range: allowed %s (%s, %s)", path, ln, group,
          named, shown, i >= 0 ? tubes_nml_vars[i].allowed : "?", i >= 0 ? tubes_nml_vars[i].doc : "",
          i >= 0 ? model_units(c, tubes_nml_vars[i].units) : "");
  if (fmt && *fmt) fprintf(err, "; %s", fmt);
  fputc('\n', err);
  return 1;
}

static int bad(const char *path, const tubes_config_t *c, const nml_where *w, const char *group, const char *name,
               FILE *err, const char *fmt, double value) {
  return bad_at(path, c, w, group, name, 0, err, fmt, value);
}

/* What variable i allows, for a message: its table entry, or for &run scenes the table of scenes
 * (tubes_scene_names, the one list the scenes are dispatched by). */
static void print_allowed(int i, FILE *err) {
  if (i >= 0 && !strcmp(tubes_nml_vars[i].group, "run") && !strcmp(tubes_nml_vars[i].name, "scenes")) {
    for (int j = 0; j < tubes_nscenes; j++) fprintf(err, "%s%s", j ? ", " : "", tubes_scene_names[j]);
  } else {
    fputs(i >= 0 ? tubes_nml_vars[i].allowed : "?", err);
  }
}

static int bad_string(const char *path, const nml_where *w, const char *group, const char *name,
                      const char *value, FILE *err) {
  int i = var_index(group, name);
  int ln = line_or_group(w, group, name);
  fprintf(err, "%s:%d: &%s: %s = '%s' is not allowed: allowed ", path, ln, group, name, value);
  print_allowed(i, err);
  fputc('\n', err);
  return 1;
}

/* &model dissipation, when given: the laws it names ('none', or viscous, rolling, noise joined by
 * '+') must be those the model's coefficients set (names, np: the system's parameters in the
 * table's order; c->params their values). One message: what was declared, what the coefficients
 * say, and how to make them agree. Returns 1 on a mismatch. */
static int check_dissipation(const char *path, const tubes_config_t *c, const nml_where *w, const char *names,
                             int np, FILE *err) {
  if (!c->dissipation[0]) return 0;
  static const char *const law[3] = {"viscous", "rolling", "noise"};
  static const char *const coef[3] = {"damping_ratio", "rolling_resistance", "noise or temperature"};
  int said[3] = {0, 0, 0}, has[3] = {0, 0, 0}, owns[3] = {0, 0, 0};
  char buf[TUBES_LNAME + 1];
  snprintf(buf, sizeof buf, "%s", c->dissipation);
  if (strcmp(buf, "none")) {
    for (char *tok = strtok(buf, "+"); tok; tok = strtok(NULL, "+")) {
      int k = 0;
      while (k < 3 && strcmp(tok, law[k])) k++;
      if (k == 3 || said[k]) return bad_string(path, w, "model", "dissipation", c->dissipation, err);
      said[k] = 1;
    }
    if (!said[0] && !said[1] && !said[2]) return bad_string(path, w, "model", "dissipation", c->dissipation, err);
  }
  for (int k = 0; k < np; k++) {
    const char *nm = names + TUBES_LPARAM * k;
    int j = !strcmp(nm, "damping_ratio") ? 0 : !strcmp(nm, "rolling_resistance") ? 1
            : (!strcmp(nm, "noise") || !strcmp(nm, "temperature")) ? 2 : -1;
    if (j < 0) continue;
    owns[j] = 1;
    has[j] |= c->params[k] > 0;
  }
  int ln = line_or_group(w, "model", "dissipation");
  for (int j = 0; j < 3; j++) {
    if (said[j] && !owns[j]) {
      fprintf(err, "%s:%d: &model: dissipation = '%s' names %s, but system '%s' has no %s (%s)\n", path, ln,
              c->dissipation, law[j], c->system, coef[j],
              j == 1 ? "rolling resistance is a ball's: rolling_ball or a formula's surface"
                     : "dissipation is defined for natural models: docs/dissipation.md#other-models");
      return 1;
    }
    if (said[j] != has[j]) {
      fprintf(err, "%s:%d: &model: dissipation = '%s' %s %s, but %s %s: %s\n", path, ln, c->dissipation,
              said[j] ? "names" : "leaves out", law[j], coef[j], said[j] ? "is 0" : "is > 0",
              said[j] ? "give its coefficient, or leave the law out" : "name the law too, or set the coefficient to 0");
      return 1;
    }
  }
  return 0;
}

/* A list of excess energies (unset entries: the reader's UNSET = -huge): no gaps, positive,
 * strictly increasing. One message, naming the element. */
static int check_list_sign(const char *path, const tubes_config_t *c, const nml_where *w, const char *group,
                           const double *de, int nde, FILE *err, int positive);
/* &orbits family's name for its code (tubes_nml io_orbits; tubes_orbits FAMILY_*) */
static const char *family_name(int code) {
  switch (code) {
  case -1: return "halo_north";
  case -2: return "halo_south";
  case -3: return "vertical";
  case -4: return "lyapunov";
  case -5: return "axial";
  default: return "?";
  }
}
static int check_list(const char *path, const tubes_config_t *c, const nml_where *w, const char *group, const double *de, int nde,
                      FILE *err) {
  return check_list_sign(path, c, w, group, de, nde, err, 1);
}

/* As check_list; positive = 0 also allows dE <= 0 (&orbits with a guess: the orbits need not lie
 * above the saddle). */
static int check_list_sign(const char *path, const tubes_config_t *c, const nml_where *w, const char *group,
                           const double *de, int nde, FILE *err, int positive) {
  int last = -1;
  for (int k = 0; k < TUBES_MAXDE; k++)
    if (de[k] != -DBL_MAX) last = k;
  for (int k = 0; k < last; k++)
    if (de[k] == -DBL_MAX) {
      fprintf(err, "%s:%d: &%s: de(%d) is not set but de(%d) is: the list has a gap; give its values from "
              "de(1) on, with none left out\n", path, line_or_group(w, group, "de"), group, k + 1, last + 1);
      return 1;
    }
  for (int k = 0; k < nde; k++) {
    if (positive && !(de[k] > 0)) return bad_at(path, c, w, group, "de", k + 1, err, "every dE must be > 0", de[k]);
    if (k > 0 && !(de[k] > de[k - 1]))
      return bad_at(path, c, w, group, "de", k + 1, err, "the list must be strictly increasing", de[k]);
  }
  return 0;
}

/* &model: the system exists, every &model variable set in the file is one of its parameters,
 * and the parameters are in range (the library's constructor decides: src/models/tubes_models.f90). */
static int validate_model(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  int ndof = 0, np = 0, si, sd;
  static char names[TUBES_MAXPARAM * TUBES_LPARAM], units[TUBES_MAXPARAM * TUBES_LUNITS],
      docs[TUBES_MAXPARAM * TUBES_LDOC];
  char sys[TUBES_LSYSTEM] = "", summary[TUBES_LSUMMARY], lu[8], sad[8], sk[8], surf[TUBES_LSUMMARY];
  double defs[TUBES_MAXPARAM], box[TUBES_MAXDOF], boxc[TUBES_MAXDOF], near[TUBES_MAXDOF], sv, sa, gate;
  snprintf(sys, sizeof sys, "%s", c->model);
  int ln = line_or_group(w, "model", "system");
  int ball = !strcmp(c->system, "rolling_ball"), formula = !strcmp(c->system, "expression");
  if (ball && strcmp(c->surface, "fourwell") && strcmp(c->surface, "expression"))
    return bad_string(path, w, "model", "surface", c->surface, err);
  formula |= ball && !strcmp(c->surface, "expression");
  /* the name the messages give the system */
  char shown[64];
  snprintf(shown, sizeof shown, "%s%s", c->system, ball && formula ? "' with surface = 'expression" : "");
  if (c->nparams == -2) {   /* a formula that did not build (src/io/tubes_expr.c says why) */
    int vl = strcmp(c->expr_var, "system") ? line_of(w, "model", c->expr_var) : 0;
    if (!vl && ball) vl = line_of(w, "model", "surface");
    if (!strcmp(c->expr_var, "system"))
      fprintf(err, "%s:%d: &model: system = '%s': %s\n", path, vl ? vl : ln, shown, c->expr_msg);
    else
      fprintf(err, "%s:%d: &model: %s: %s\n", path, vl ? vl : ln, c->expr_var, c->expr_msg);
    return 1;
  }
  if (c->nparams < 0 || tubes_model_info(sys, &ndof, &np, names, defs, units, docs, summary, lu, box, boxc, sad,
                                         near, sk, &si, &sv, &sd, &sa, &gate, surf) < 0) {
    fprintf(err, "%s:%d: &model: system = '%s' is not a built-in system: allowed ", path, ln, c->system);
    char nm[TUBES_LSYSTEM];
    for (int k = 0; tubes_model_system(k, nm) == TUBES_OK; k++) fprintf(err, "%s%s", k ? ", " : "", nm);
    fprintf(err, ", or expression (a Hamiltonian written as a formula: docs/models.md)\n");
    return 1;
  }
  int n = 0;
  for (int i = 0; i < tubes_nml_nvars; i++) {
    const nml_var *v = &tubes_nml_vars[i];
    if (strcmp(v->group, "model") || !strcmp(v->name, "system") || !w->var_line[i]) continue;
    int mine = 0;
    for (int k = 0; k < np; k++) mine |= !strcmp(names + TUBES_LPARAM * k, v->name);
    static const char *const ham_vars[] = {"hamiltonian", "coordinates", "momenta", "constants"};
    for (int k = 0; k < 4 && formula && !ball; k++) mine |= !strcmp(v->name, ham_vars[k]);
    mine |= ball && !strcmp(v->name, "surface");
    mine |= !strcmp(v->name, "dissipation");
    mine |= !strcmp(v->name, "spatial") && !strcmp(c->system, "cr3bp");
    mine |= ball && formula && (!strcmp(v->name, "height") || !strcmp(v->name, "constants"));
    if (mine) continue;
    fprintf(err, "%s:%d: &model: %s is not a parameter of system '%s' (its parameters: ", path,
            w->var_line[i], v->name, shown);
    for (int k = 0; k < np; k++) fprintf(err, "%s%s", k ? ", " : "", names + TUBES_LPARAM * k);
    if (formula && !ball) fprintf(err, "%shamiltonian, coordinates, momenta, constants", np ? ", " : "");
    if (ball) fprintf(err, ", surface%s", formula ? ", height, constants" : "");
    fprintf(err, "%s)\n", np || formula || ball ? "" : "none");
    n++;
  }
  if (n) return n;
  for (int k = 0; k < np; k++)
    if (!isfinite(c->params[k])) {
      n += bad(path, c, w, "model", names + TUBES_LPARAM * k, err, "must be finite", c->params[k]);
    }
  if (n) return n;
  if (!strcmp(sys, "rolling_ball")) {
    if (!(c->alpha > 0)) n += bad(path, c, w, "model", "alpha", err, "", c->alpha);
    if (!(c->beta >= 0)) n += bad(path, c, w, "model", "beta", err, "", c->beta);
    if (!(c->gamma > 0)) n += bad(path, c, w, "model", "gamma", err, "", c->gamma);
    if (!(c->g > 0)) n += bad(path, c, w, "model", "g", err, "", c->g);
    if (n) return n;
  }
  for (int k = 0; k < np; k++) {   /* the dissipation of any model that has it (its table's entries) */
    const char *nm = names + TUBES_LPARAM * k;
    if (!strcmp(nm, "g") && formula && !(c->params[k] > 0)) n += bad(path, c, w, "model", "g", err, "", c->params[k]);
    if (!strcmp(nm, "damping_ratio") && !(c->params[k] >= 0 && c->params[k] < 1))
      n += bad(path, c, w, "model", "damping_ratio", err, "", c->params[k]);
    if (!strcmp(nm, "rolling_resistance") && !(c->params[k] >= 0 && c->params[k] < 1))
      n += bad(path, c, w, "model", "rolling_resistance", err, "", c->params[k]);
  }
  if (n) return n;
  for (int k = 0, kz = -1, kn = -1, kt = -1; k <= np; k++) {   /* noise */
    const char *nm = k < np ? names + TUBES_LPARAM * k : "";
    if (!strcmp(nm, "damping_ratio")) kz = k;
    if (!strcmp(nm, "noise")) kn = k;
    if (!strcmp(nm, "temperature")) kt = k;
    if (k < np) continue;
    if (kn >= 0 && !(c->params[kn] >= 0)) n += bad(path, c, w, "model", "noise", err, "", c->params[kn]);
    if (kt >= 0 && !(c->params[kt] >= 0)) n += bad(path, c, w, "model", "temperature", err, "", c->params[kt]);
    if (n) return n;
    if (kn >= 0 && kt >= 0 && c->params[kn] > 0 && c->params[kt] > 0) {
      fprintf(err, "%s:%d: &model: noise = %g and temperature = %g: give one (noise: its strength D; temperature: the "
              "noise the fluctuation-dissipation relation gives with damping_ratio)\n", path,
              line_or_group(w, "model", "temperature"), c->params[kn], c->params[kt]);
      return 1;
    }
    if (kt >= 0 && c->params[kt] > 0 && !(kz >= 0 && c->params[kz] > 0)) {
      fprintf(err, "%s:%d: &model: temperature = %g needs damping_ratio > 0: the fluctuation-dissipation relation's "
              "noise is 2 c theta A^-1 with c the viscous rate (or give noise = D instead)\n", path,
              line_or_group(w, "model", "temperature"), c->params[kt]);
      return 1;
    }
  }
  if (check_dissipation(path, c, w, names, np, err)) return 1;
  int natural = 0;
  if (tubes_model_natural(sys, c->params, &natural) < 0) {
    fprintf(err, "%s:%d: &model: the parameters of system '%s' are out of range:", path, ln, sys);
    for (int k = 0; k < np; k++)
      fprintf(err, "%s %s = %.15g (%s)", k ? "," : "", names + TUBES_LPARAM * k, c->params[k], docs + TUBES_LDOC * k);
    fputc('\n', err);
    return 1;
  }
  return 0;
}

static int scene_requested(const tubes_config_t *c, const char *name) {
  for (int k = 0; k < TUBES_NSCENES; k++)
    if (!strcmp(c->scenes[k], name)) return 1;
  return 0;
}

/* &equilibria box, &orbits saddle / saddle_near, &section for the chosen system. */
static int in_registered_range(const tubes_config_t *c, const char *group, const char *name);   /* below */

static int validate_geometry(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  int n = 0, nd = c->ndof;
  /* a value for a coordinate the model does not have (0 is let through: the effective namelist
   * writes 0 there, and it reads back to the same run) */
  static const char *const per_dof[][2] = {{"equilibria", "box"}, {"equilibria", "box_center"},
                                           {"orbits", "saddle_near"}};
  for (int j = 0; j < 3; j++) {
    int i = var_index(per_dof[j][0], per_dof[j][1]);
    if (w->var_nonzero[i] > nd) {
      fprintf(err, "%s:%d: &%s: %s(%d) = %.17g is a value for coordinate %d, but system '%s' has %d: give at "
              "most %d values%s\n", path, w->var_line[i], per_dof[j][0], per_dof[j][1], w->var_nonzero[i],
              w->var_nonzero_value[i], w->var_nonzero[i], c->system, nd, nd,
              j == 0 ? " (one value sets every coordinate)" : "");
      n++;
    }
  }
  /* one value of box is every coordinate's: one message; several, a message per element */
  int one_box = w->var_last[var_index("equilibria", "box")] <= 1;
  for (int k = 0; k < nd; k++)
    if (!(c->box_list[k] > 0 && c->box_list[k] < DBL_MAX)) {
      n += bad_at(path, c, w, "equilibria", "box", one_box ? 0 : k + 1, err, "every half-width must be > 0",
                  c->box_list[k]);
      if (one_box) break;
    }
  for (int k = 0; k < nd; k++)
    if (!isfinite(c->box_center[k])) n += bad_at(path, c, w, "equilibria", "box_center", k + 1, err, "", c->box_center[k]);
  if (in_registered_range(c, "equilibria", "n_grid") && pow(c->n_grid, nd) > 1e6)   /* its rule: by the model's N */
    n += bad(path, c, w, "equilibria", "n_grid", err, "n_grid^N Newton starts at most 1e6", c->n_grid);
  if (line_of(w, "orbits", "saddle") && line_of(w, "orbits", "saddle_near")) {
    fprintf(err, "%s:%d: &orbits: saddle and saddle_near are both set: choose the saddle by name or by "
            "position, not both\n", path, line_of(w, "orbits", "saddle_near"));
    n++;
  }
  if (strlen(c->orb_saddle) > 7) n += bad_string(path, w, "orbits", "saddle", c->orb_saddle, err);
  for (int k = 0; k < nd; k++)
    if (c->orb_use_near && !isfinite(c->orb_saddle_near[k]))
      n += bad_at(path, c, w, "orbits", "saddle_near", k + 1, err, "", c->orb_saddle_near[k]);
  /* the saddles are searched in the box: a point outside it would get the nearest saddle inside it, however far */
  for (int k = 0; k < nd && c->orb_use_near; k++)
    if (isfinite(c->orb_saddle_near[k]) && fabs(c->orb_saddle_near[k] - c->box_center[k]) > c->box_list[k]) {
      int ln = line_of(w, "orbits", "saddle_near");
      fprintf(err, "%s:%d: &orbits: saddle_near%s = (", path, ln ? ln : line_of(w, "equilibria", "box"),
              ln ? "" : " (the system's default)");
      for (int i = 0; i < nd; i++) fprintf(err, "%s%.10g", i ? ", " : "", c->orb_saddle_near[i]);
      fprintf(err, ") lies outside the &equilibria box, where the saddles are searched: coordinate %d is %.10g from "
              "the box's centre %.10g, the box's half-width is %.10g; allowed: within the box (widen &equilibria box, "
              "or move box_center)\n", k + 1, fabs(c->orb_saddle_near[k] - c->box_center[k]), c->box_center[k],
              c->box_list[k]);
      n++;
      break;
    }
  if (scene_requested(c, "synthetic_experiment") && !strcmp(c->system, "rolling_ball") &&
      strcmp(c->surface, "fourwell")) {
    fprintf(err, "%s:%d: &run: the synthetic_experiment scene models the paper's machined four-well surface: it "
            "needs surface = 'fourwell', not '%s'\n", path, line_of(w, "run", "scenes"), c->surface);
    n++;
  }
  if (scene_requested(c, "synthetic_experiment") && strcmp(c->system, "rolling_ball")) {
    fprintf(err, "%s:%d: &run: the synthetic_experiment scene releases balls on the four-well surface: it needs "
            "system = 'rolling_ball', not '%s'\n", path, line_of(w, "run", "scenes"), c->system);
    n++;
  }
  if (scene_requested(c, "trajectory") && c->at_rest && strcmp(c->system, "rolling_ball")) {
    int natural = 0;
    tubes_model_natural(c->model, c->params, &natural);
    if (!natural) {
      fprintf(err, "%s:%d: &trajectory: at_rest = .true. (the default) needs a natural system; system '%s' is "
              "gyroscopic: set at_rest = .false. and give px0, py0 (zero velocity is p = (-y0, x0) for cr3bp)\n",
              path, line_or_group(w, "trajectory", "at_rest"), c->system);
      n++;
    }
  }
  if (scene_requested(c, "flux")) {
    if (nd < 2) {
      fprintf(err, "%s:%d: &run: the flux scene needs 2 or 3 degrees of freedom (system '%s' has %d)\n", path,
              line_of(w, "run", "scenes"), c->system, nd);
      n++;
    }
  }
  int need_section = scene_requested(c, "tubes") || scene_requested(c, "transition") ||
                     scene_requested(c, "montecarlo") || scene_requested(c, "sections") ||
                     (scene_requested(c, "scan") && c->scan_p_trans);
  int set_ray = line_of(w, "section", "angle") || line_of(w, "section", "p_theta_sign");
  int set_plane = line_of(w, "section", "index") || line_of(w, "section", "value") ||
                  line_of(w, "section", "direction");
  int gl = w->group_line[group_index("section")];
  if (!c->sec_kind[0]) {
    if (need_section) {
      fprintf(err, "%s: &section: system '%s' has no default section; set kind = 'plane', index, value "
              "and direction (docs/tubes.md, Sections)\n", path, c->system);
      n++;
    }
  } else if (!strcmp(c->sec_kind, "ray")) {
    if (strcmp(c->system, "rolling_ball")) {
      fprintf(err, "%s:%d: &section: kind = 'ray' is the four-well ball's polar section; system '%s' takes "
              "kind = 'plane' (index, value, direction)\n", path, line_or_group(w, "section", "kind"),
              c->system);
      n++;
    } else if (set_plane) {
      fprintf(err, "%s:%d: &section: index, value and direction belong to kind = 'plane'; kind = 'ray' takes "
              "angle and p_theta_sign\n", path, gl);
      n++;
    }
    if (!(c->sec_angle >= -360 && c->sec_angle <= 360)) n += bad(path, c, w, "section", "angle", err, "", c->sec_angle);
    if (c->sec_pth_sign != 1 && c->sec_pth_sign != -1)
      n += bad(path, c, w, "section", "p_theta_sign", err, "", c->sec_pth_sign);
  } else if (!strcmp(c->sec_kind, "plane")) {
    if (set_ray) {
      fprintf(err, "%s:%d: &section: angle and p_theta_sign belong to kind = 'ray'; kind = 'plane' takes "
              "index, value and direction\n", path, gl);
      n++;
    }
    if (!(c->sec_index >= 1 && c->sec_index <= nd)) {
      fprintf(err, "%s:%d: &section: index = %d is out of range: allowed 1 .. %d (the coordinates of system "
              "'%s')\n", path, line_or_group(w, "section", "index"), c->sec_index, nd, c->system);
      n++;
    }
    if (!(c->sec_direction == 1 || c->sec_direction == -1))
      n += bad(path, c, w, "section", "direction", err, "", c->sec_direction);
    if (!isfinite(c->sec_value) || c->sec_value == -DBL_MAX)
      n += bad(path, c, w, "section", "value", err, "", c->sec_value);
  } else {
    n += bad_string(path, w, "section", "kind", c->sec_kind, err);
  }
  return n;
}

/* The memory a scene's arrays take, from the input's sizes (the largest arrays the scene holds at
 * once: the C buffers the scenes allocate, docs/input.md "Memory"), against the machine's memory:
 * a request larger than the machine is refused here, by --check and before any work, not by a
 * failed allocation hours later. */
static int check_memory(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  double mem = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGE_SIZE);
  struct rlimit rl;
  if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && (double)rl.rlim_cur < mem)
    mem = (double)rl.rlim_cur;
  if (!(mem > 0)) return 0;   /* not known here: the allocations' own checks remain */
  double nout = c->dt_out > 0 ? floor(c->t_end / c->dt_out) + 2 : 0;
  double frames = c->exp_duration > 0 && c->exp_camera_rate > 0 && c->exp_duration * c->exp_camera_rate <= 1e6
                      ? (double)tubes_experiment_samples(c->exp_duration, c->exp_camera_rate) * c->exp_n_tracks : 0;
  struct { const char *scene, *group, *name, *what, *lower; double bytes; } need[] = {
      {"trajectory", "trajectory", "dt_out", "t_end/dt_out samples (48 bytes each) and max_crossings crossings (44)",
       "t_end or max_crossings, or raise dt_out",
       48 * nout + 44.0 * c->max_crossings},
      {"orbits", "orbits", "n_samples", "n_samples x (number of de) x max_iter (56 and 8 bytes each)",
       "n_samples or max_iter",
       56.0 * c->orb_n_samples * c->orb_nde + 8.0 * c->orb_max_iter * c->orb_nde},
      {"montecarlo", "montecarlo", "n_samples", "n_samples points (24 bytes each)", "n_samples", 24.0 * c->mc_n_samples},
      {"sections", "sections", "n_iter", "n_seeds x n_iter returns (16 bytes each)", "n_seeds or n_iter",
       16.0 * c->pm_n_seeds * c->pm_n_iter},
      {"synthetic_experiment", "experiment", "n_tracks", "n_tracks x duration x camera_rate frames (108 bytes each)",
       "n_tracks, duration or camera_rate",
       108 * frames},
  };
  int n = 0;
  for (size_t k = 0; k < sizeof need / sizeof need[0]; k++) {
    if (!scene_requested(c, need[k].scene) || need[k].bytes <= mem) continue;
    fprintf(err, "%s:%d: &%s: the %s scene needs %.3g GB of memory for its %s; this machine has %.3g GB (the "
            "physical memory, or the address-space limit if lower): lower %s\n", path,
            line_or_group(w, need[k].group, need[k].name), need[k].group, need[k].scene, need[k].bytes / 1e9,
            need[k].what, mem / 1e9, need[k].lower);
    n++;
  }
  return n;
}

/* &scan (docs/scan.md): checked where the scan scene is asked for or the group is given. */
static int validate_scan(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  int asked = 0, n = 0;
  double start = 0;
  for (int i = 0; i < TUBES_NSCENES; i++) asked |= !strcmp(c->scenes[i], "scan");
  if (!asked && !w->group_line[group_index("scan")]) return 0;
  if (!c->scan_parameter[0]) {
    fprintf(err, "%s:%d: &scan: parameter is not set: the scan scene needs the name of the parameter to move "
            "(a parameter of system '%s' in &model)\n", path, line_or_group(w, "scan", "parameter"), c->system);
    n++;
  } else if (c->nparams >= 0 && c->scan_ipar < 1) {
    char allowed[512];
    tubes_scan_parameter(c->model, c->scan_parameter, allowed, (int)sizeof allowed);
    fprintf(err, "%s:%d: &scan: parameter = '%s' is not a parameter the scan takes for system '%s'; allowed: %s%s\n",
            path, line_or_group(w, "scan", "parameter"), c->scan_parameter, c->system,
            allowed[0] ? allowed : "none",
            c->nparams == 0 || !strcmp(c->system, "expression") || !strcmp(c->surface, "expression")
                ? " (a formula's constants given as numbers are scanned, not one defined by a formula of "
                  "others; dissipation parameters are not scanned)"
                : " (dissipation parameters are not scanned: the scan follows the conservative model)");
    n++;
  }
  if (c->scan_to == -DBL_MAX) {
    fprintf(err, "%s:%d: &scan: to is not set: the scan scene needs the parameter's end value\n", path,
            line_or_group(w, "scan", "to"));
    n++;
  } else if (c->scan_ipar >= 1 && tubes_scan_start(c->model, c->params, c->scan_ipar, &start) == 0 &&
             c->scan_to == start) {
    fprintf(err, "%s:%d: &scan: to = %.17g equals the start value %s = %.17g (&model): allowed any other value\n",
            path, line_or_group(w, "scan", "to"), c->scan_to, c->scan_parameter, start);
    n++;
  } else if (c->scan_ipar > TUBES_SCAN_CONSTANT) {   /* a formula's constant: its library at the end value */
    char key[TUBES_LSYSTEM], msg[2048];
    if (tubes_expr_with_constant(c->model, c->scan_parameter, c->scan_to, key, msg, (int)sizeof msg)) {
      fprintf(err, "%s:%d: &scan: to = %.10g: the formula's library with %s\n", path, line_or_group(w, "scan", "to"),
              c->scan_to, msg);
      n++;
    }
  } else if (c->scan_ipar >= 1 && c->scan_ipar <= c->nparams) {   /* the end value: the model's own check */
    double p[TUBES_MAXPARAM];
    int natural = 0;
    memcpy(p, c->params, sizeof p);
    p[c->scan_ipar - 1] = c->scan_to;
    if (tubes_model_natural(c->model, p, &natural) < 0) {
      fprintf(err, "%s:%d: &scan: to = %.10g: system '%s' refuses %s = %.10g (its range: docs/models.md, "
              "--help's &model)\n", path, line_or_group(w, "scan", "to"), c->scan_to, c->system,
              c->scan_parameter, c->scan_to);
      n++;
    }
  }
  if (line_of(w, "scan", "de")) n += check_list(path, c, w, "scan", c->scan_de, c->scan_nde, err);
  if (c->scan_p_trans && c->scan_nde == 0) {
    fprintf(err, "%s:%d: &scan: p_trans = .true. needs the excess energies: set &scan de (or &orbits de), > 0 and "
            "increasing\n", path, line_or_group(w, "scan", "p_trans"));
    n++;
  }
  if (asked && c->orb_family != 1 && c->scan_nde > 0) {
    fprintf(err, "%s:%d: &orbits: family: the scan scene follows the orbits of family 1 (the saddle's lowest centre "
            "frequency; docs/scan.md): allowed family = 1 with the scan, or no orbits (no &scan de or &orbits de)\n",
            path, line_or_group(w, "orbits", "family"));
    n++;
  }
  return n;
}

/* &orbits jacobi, periods (docs/orbits.md, "Orbits by Jacobi constant or period"): at most one of de,
 * jacobi, periods; jacobi for a model with a Jacobi constant (the model's, tubes_jacobi_constant),
 * decreasing; periods > 0, for any family but 'branch:K'; the scan scene takes &orbits de only. */
static int check_orbit_parameter(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  const char *given[3];
  int ng = 0, n = 0;
  if (c->orb_de_given) given[ng++] = "de";
  if (c->orb_njacobi > 0) given[ng++] = "jacobi";
  if (c->orb_nperiods > 0) given[ng++] = "periods";
  if (ng > 1) {
    fprintf(err, "%s:%d: &orbits: %s and %s are both given: the orbits are asked for by one parameter (allowed: "
            "exactly one of de (the excess energy), jacobi (the Jacobi constant C), periods)\n", path,
            line_or_group(w, "orbits", given[1]), given[0], given[1]);
    return 1;
  }
  if (c->orb_njacobi > 0 && c->nparams >= 0) {
    double e = 0, cc = 0;
    if (tubes_jacobi_constant(c->model, c->params, 1, &e, &cc) < 0) {
      fprintf(err, "%s:%d: &orbits: jacobi: system '%s' has no Jacobi constant (allowed: a model that defines one, "
              "system 'cr3bp' (C = -2 H, planar or spatial); for this model give de)\n", path,
              line_or_group(w, "orbits", "jacobi"), c->system);
      n++;
    }
    for (int k = 0; k < c->orb_njacobi; k++) {
      if (c->orb_jacobi[k] == -DBL_MAX)
        return n + bad_at(path, c, w, "orbits", "jacobi", k + 1, err, "not set but a later value is: the list has a "
                          "gap; give its values from jacobi(1) on", c->orb_jacobi[k]);
      if (!isfinite(c->orb_jacobi[k]))
        return n + bad_at(path, c, w, "orbits", "jacobi", k + 1, err, "every C must be finite", c->orb_jacobi[k]);
      if (k > 0 && !(c->orb_jacobi[k] < c->orb_jacobi[k - 1]))
        return n + bad_at(path, c, w, "orbits", "jacobi", k + 1, err, "the list must be strictly decreasing (the "
                          "orbits' energies E = -C/2 increasing)", c->orb_jacobi[k]);
    }
  }
  if (c->orb_nperiods > 0) {
    for (int k = 0; k < c->orb_nperiods; k++)
      if (c->orb_periods[k] == -DBL_MAX)
        return n + bad_at(path, c, w, "orbits", "periods", k + 1, err, "not set but a later value is: the list has "
                          "a gap; give its values from periods(1) on", c->orb_periods[k]);
      else if (!(c->orb_periods[k] > 0) || !isfinite(c->orb_periods[k]))

        return n + bad_at(path, c, w, "orbits", "periods", k + 1, err, "every period must be > 0", c->orb_periods[k]);
    if (c->orb_family <= -101) {   /* 'branch:K' (-100 - K): K counts the parent's bifurcations between the de */
      fprintf(err, "%s:%d: &orbits: periods: not for family = 'branch:%d': its K counts the parent family's "
              "bifurcations between the requested energies, which periods do not give (allowed: periods with "
              "family 1 .. N-1, 'lyapunov', 'vertical', 'halo_north', 'halo_south', 'axial' or a guess; ask for the "
              "branch by de or jacobi)\n", path, line_or_group(w, "orbits", "periods"), -100 - c->orb_family);
      n++;
    }
  }
  if (c->orb_njacobi + c->orb_nperiods > 0 && c->scan_nde == 0)
    for (int k = 0; k < TUBES_NSCENES; k++)
      if (!strcmp(c->scenes[k], "scan")) {
        fprintf(err, "%s:%d: &orbits: %s: the scan scene follows the orbits at &orbits de only (docs/scan.md): "
                "give &scan de for its orbits (the scan takes &orbits de, not jacobi or periods)\n", path,
                line_or_group(w, "orbits", c->orb_njacobi ? "jacobi" : "periods"), c->orb_njacobi ? "jacobi" : "periods");
        n++;
        break;
      }
  return n;
}

/* The registered variables' ranges (src/workflow/tubes_config.f90's annotations, build/include/tubes_registry.h):
 * each field's value against its bounds, the message bad()'s with the row's allowed text. */
static const struct {
  const char *group, *name;
  size_t offset;
  int is_int;   /* 0 a real, 1 an integer (int), 2 a 64-bit integer (int64_t) */
  double lo, hi;
  int lo_open, hi_open;
  long lo_at;   /* >= 0: the lower bound is the field at this offset (allowed "OTHER .. HI"), of the same type */
  int alt_ok;   /* 1: the value alt is allowed too (allowed "0, or LO .. HI") */
  double alt;
  int even;     /* 1: only even values in [lo, hi] (allowed "0, or even LO .. HI") */
} reg[] = {TUBES_REGISTRY_RANGES};

/* The number at offset of the settings: a real, an integer (is_int 1) or a 64-bit integer (2). */
static double field_value(const tubes_config_t *c, size_t offset, int is_int) {
  const char *p = (const char *)c + offset;
  double x;
  if (is_int == 2) {   /* a 64-bit integer (max_steps) */
    int64_t i;
    memcpy(&i, p, sizeof i);
    x = (double)i;
  } else if (is_int) {
    int i;
    memcpy(&i, p, sizeof i);
    x = i;
  } else memcpy(&x, p, sizeof x);
  return x;
}

/* Whether registered number k of the settings is in its annotation's range. */
static int registered_ok(const tubes_config_t *c, int k) {
  double x = field_value(c, reg[k].offset, reg[k].is_int);
  double lo = reg[k].lo_at >= 0 ? field_value(c, (size_t)reg[k].lo_at, reg[k].is_int) : reg[k].lo;
  int ok = (reg[k].lo_open ? x > lo : x >= lo) && (reg[k].hi_open ? x < reg[k].hi : x <= reg[k].hi) &&
           (!reg[k].even || fmod(x, 2) == 0);
  return ok || (reg[k].alt_ok && x == reg[k].alt);
}

/* Whether group.name, a registered number, is in its range (a rule kept by hand beside it, "FORM, RULE",
 * judges only a value the range allows: check_registered has said the rest). */
static int in_registered_range(const tubes_config_t *c, const char *group, const char *name) {
  for (int k = 0; k < TUBES_REGISTRY_N; k++)
    if (reg[k].group && !strcmp(reg[k].group, group) && !strcmp(reg[k].name, name)) return registered_ok(c, k);
  return 0;
}

/* A registered number's range for a caller that takes the value outside a file (Python's
 * tubes.integrate, tubes.scan): 1 with its bounds (+-INFINITY where open-ended, +-DBL_MAX for
 * "finite"), whether they are open, whether it is an integer, and the allowed text of its messages
 * (NUL-terminated, at most len bytes); 2 for a registered string, its values in allowed; 0 when
 * group/name is not registered. */
int tubes_registry_range(const char *group, const char *name, double *lo, double *hi, int *lo_open, int *hi_open,
                         int *is_int, char *allowed, int len) {
  for (int k = 0; k < TUBES_REGISTRY_N; k++) {
    if (!reg[k].group || strcmp(reg[k].group, group) || strcmp(reg[k].name, name)) continue;
    *lo = reg[k].lo;
    *hi = reg[k].hi;
    *lo_open = reg[k].lo_open;
    *hi_open = reg[k].hi_open;
    *is_int = reg[k].is_int;
    int i = var_index(group, name);
    snprintf(allowed, (size_t)len, "%s", i >= 0 ? tubes_nml_vars[i].allowed : "");
    return 1;
  }
  for (int k = 0; k < TUBES_REGISTRY_NS; k++) {   /* a registered string: 2 and its values */
    if (strcmp(reg_str[k].group, group) || strcmp(reg_str[k].name, name)) continue;
    *lo = *hi = 0;
    *lo_open = *hi_open = *is_int = 0;
    snprintf(allowed, (size_t)len, "%s", reg_str[k].values);
    return 2;
  }
  return 0;
}

static int check_registered(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  int n = 0;
  for (int k = 0; k < TUBES_REGISTRY_N; k++)
    if (!registered_ok(c, k)) n += bad(path, c, w, reg[k].group, reg[k].name, err, "", field_value(c, reg[k].offset, reg[k].is_int));
  /* the lists of excess energies; one whose default is another's list only where the file sets it */
  static const struct {
    const char *group, *name;
    size_t offset, count;
    int only_set;
  } lst[] = {TUBES_REGISTRY_LISTS};
  for (int k = 0; k < TUBES_REGISTRY_NL; k++) {
    int nde;
    memcpy(&nde, (const char *)c + lst[k].count, sizeof nde);
    if (!lst[k].only_set || line_of(w, lst[k].group, lst[k].name))
      n += check_list(path, c, w, lst[k].group, (const double *)((const char *)c + lst[k].offset), nde, err);
  }
  /* the strings: one of their values (the allowed text's, ", " between them) */
  for (int k = 0; k < TUBES_REGISTRY_NS; k++) {
    const char *v = (const char *)c + reg_str[k].offset;
    if (!registered_value(reg_str[k].group, reg_str[k].name, v))
      n += bad_string(path, w, reg_str[k].group, reg_str[k].name, v, err);
  }
  return n;
}

int nml_validate(const char *path, const tubes_config_t *c, const nml_where *w, FILE *err) {
  int n = 0, nscenes = 0;
  for (int k = 0; k < TUBES_NSCENES; k++) {
    const char *s = c->scenes[k];
    if (!s[0]) continue;
    nscenes++;
    int ok = 0;
    for (int j = 0; j < tubes_nscenes; j++) ok |= strcmp(s, tubes_scene_names[j]) == 0;
    if (!ok) n += bad_string(path, w, "run", "scenes", s, err);
    for (int j = 0; j < k; j++)
      if (!strcmp(s, c->scenes[j])) {
        fprintf(err, "%s:%d: &run: scene '%s' is named twice in scenes: each scene runs once\n", path,
                line_of(w, "run", "scenes"), s);
        n++;
        break;
      }
  }
  for (int k = 0, last = -1; k < TUBES_NSCENES; k++) {   /* a gap: scenes(1) = ..., scenes(3) = ... */
    for (int j = k; j < TUBES_NSCENES; j++)
      if (c->scenes[j][0]) last = j;
    if (!c->scenes[k][0] && k < last) {
      fprintf(err, "%s:%d: &run: scenes(%d) is empty but scenes(%d) = '%s' follows: name the scenes from scenes(1) "
              "on, with none left out\n", path, line_of(w, "run", "scenes"), k + 1, last + 1, c->scenes[last]);
      n++;
      break;
    }
  }
  if (nscenes == 0) {
    fprintf(err, "%s:%d: &run: scenes is empty: name at least one of ", path, line_of(w, "run", "scenes"));
    for (int j = 0; j < tubes_nscenes; j++) fprintf(err, "%s'%s'", j ? ", " : "", tubes_scene_names[j]);
    fputc('\n', err);
    n++;
  }
  if (!c->output[0]) n += bad_string(path, w, "run", "output", "", err);
  int nm = validate_model(path, c, w, err);
  n += nm;
  if (!nm && c->nparams >= 0) n += validate_geometry(path, c, w, err);
  if (c->dt_out > 0 && c->t_end / c->dt_out > 5.0e7)   /* t_end, dt_out themselves: check_registered */
    n += bad(path, c, w, "trajectory", "dt_out", err, "t_end/dt_out exceeds 5e7 samples", c->dt_out);
  /* method, its values: check_registered */
  if (tubes_method_code(c->method) >= TUBES_METHOD_RK4 && tubes_method_code(c->method) <= TUBES_METHOD_GAUSS8 &&
           !(c->h > 0)) {
    int ln = line_of(w, "integrator", "h") ? line_of(w, "integrator", "h") : line_of(w, "integrator", "method");
    fprintf(err, "%s:%d: &integrator: method = '%s' is fixed-step: it needs h > 0 (the step [%s]); h = %g\n", path,
            ln, c->method, model_units(c, "s"), c->h);
    n++;
  }
  if (tubes_method_code(c->method) == TUBES_METHOD_DOP853 && c->h > 0 &&
      (line_of(w, "integrator", "rtol") || line_of(w, "integrator", "atol"))) {
    /* DOP853 with h > 0 takes fixed steps of h (to measure its order): tolerances asked for too are
     * a request it would silently not honour */
    int ln = line_of(w, "integrator", "h") ? line_of(w, "integrator", "h") : line_of(w, "integrator", "method");
    fprintf(err, "%s:%d: &integrator: method = 'dop853' with h = %g takes fixed steps of h without error control, "
            "but rtol or atol is set too and would not be used: allowed h = 0 (steps controlled by rtol and atol) or "
            "h > 0 without rtol and atol\n", path, ln, c->h);
    n++;
  }
  if (c->omega_bind > 0 && tubes_method_code(c->method) >= TUBES_METHOD_TAO2 && tubes_method_code(c->method) <= TUBES_METHOD_TAO6 &&
           c->h > 0 && !(2 * c->omega_bind * c->h < M_PI)) {
    /* Tao's coupling flow rotates by 2 omega h a step: at pi and beyond the method blows up
     * (docs/integrators-tao.md, "Hard limit") */
    int ln = line_of(w, "integrator", "h") ? line_of(w, "integrator", "h") : line_of(w, "integrator", "omega_bind");
    fprintf(err, "%s:%d: &integrator: method = '%s' with h = %g and omega_bind = %g: 2 omega_bind h = %g is not "
            "below pi, where Tao's coupling flow makes the method blow up (docs/integrators-tao.md): allowed "
            "2 omega_bind h < pi (h < %.3g at this omega_bind; its order needs 2 omega_bind h <= ~0.4)\n", path, ln,
            c->method, c->h, c->omega_bind, 2 * c->omega_bind * c->h, M_PI / (2 * c->omega_bind));
    n++;
  }
  n += check_list_sign(path, c, w, "orbits", c->orb_de, c->orb_nde, err, c->orb_nguess == 0);
  /* a family from a guess (docs/orbits.md, "Orbits from a guess") */
  if (c->orb_nguess > 0 && c->nparams >= 0 && c->orb_nguess != 2 * c->ndof) {
    fprintf(err, "%s:%d: &orbits: guess has %d value%s: allowed exactly 2N = %d (the state: the %d coordinates, "
            "then the %d momenta, of system '%s')\n", path, line_or_group(w, "orbits", "guess"), c->orb_nguess,
            c->orb_nguess == 1 ? "" : "s", 2 * c->ndof, c->ndof, c->ndof, c->system);
    n++;
  }
  if (c->orb_nguess > 0 && !(c->orb_period > 0)) {
    fprintf(err, "%s:%d: &orbits: period = %g: the guess's period must be > 0 (allowed: a time > 0)\n", path,
            line_or_group(w, "orbits", "period"), c->orb_period);
    n++;
  } else if (c->orb_nguess == 0 && c->orb_period != 0) {
    fprintf(err, "%s:%d: &orbits: period = %g is the period of a guess, but guess is not set (allowed: both, or "
            "neither)\n", path, line_or_group(w, "orbits", "period"), c->orb_period);
    n++;
  }
  if (c->orb_nguess > 0 && c->orb_family < 0 && c->orb_family >= -5) {
    fprintf(err, "%s:%d: &orbits: family = '%s' with a guess: a family by name starts at its saddle or branch point, "
            "not from a guess (allowed with guess: family = 1 (the guess's own family) or 'branch:K')\n", path,
            line_or_group(w, "orbits", "family"), family_name(c->orb_family));
    n++;
  }
  n += check_orbit_parameter(path, c, w, err);
  if (c->orb_family == -99) {
    fprintf(err, "%s:%d: &orbits: family: the name is not one of the families: allowed 1 .. N-1 (the saddle's "
            "centre modes), 'lyapunov' (family 1; in 3 degrees of freedom the planar one), 'vertical' (the centre "
            "mode out of the plane, in q_N, p_N), 'halo_north', 'halo_south' (the branch off family N-1 at its "
            "first branch point), 'axial' (the branch off the planar family that ends on the vertical one; these "
            "four: 3 degrees of freedom), 'branch:K' (K >= 1: the family from the K-th bifurcation detected along "
            "the guess's family, or without a guess family 1)\n", path, line_or_group(w, "orbits", "family"));
    n++;
  } else if (c->orb_family <= -101 || c->orb_family == -4) {
    /* branch:K: any model (multiple shooting, no symmetry); 'lyapunov': any number of degrees of freedom */
  } else if (c->orb_family < 0 && c->nparams >= 0 && c->ndof != 3) {
    fprintf(err, "%s:%d: &orbits: family = '%s' needs 3 degrees of freedom (%s): system '%s' has %d\n", path,
            line_or_group(w, "orbits", "family"), family_name(c->orb_family),
            c->orb_family == -3 ? "the vertical family is the centre mode out of the plane q_N = p_N = 0"
            : c->orb_family == -5 ? "the axial family branches off the planar Lyapunov family out of the plane"
            : "the halo family branches off the planar Lyapunov family", c->system, c->ndof);
    n++;
  } else if ((c->orb_family == -1 || c->orb_family == -2) && !strcmp(c->orb_method, "multiple")) {
    fprintf(err, "%s:%d: &orbits: family = '%s' is continued by single shooting of the symmetric orbit: "
            "method = 'multiple' is not supported for it (allowed: method = 'single')\n", path,
            line_or_group(w, "orbits", "method"), c->orb_family == -1 ? "halo_north" : "halo_south");
    n++;
  } else if (c->orb_family >= 0 && c->nparams >= 0 &&
             !(c->orb_family >= 1 && c->orb_family <= (c->ndof > 1 ? c->ndof - 1 : 1))) {
    fprintf(err, "%s:%d: &orbits: family = %d is out of range: allowed 1 .. %d (the saddle's centre modes; "
            "system '%s' has %d degrees of freedom), or 'halo_north', 'halo_south'\n", path,
            line_or_group(w, "orbits", "family"), c->orb_family, c->ndof > 1 ? c->ndof - 1 : 1, c->system, c->ndof);
    n++;
  }
  n += check_registered(path, c, w, err);
  if (c->nparams >= 0 && !(c->mc_gate > 0 && c->mc_gate < DBL_MAX))
    n += bad(path, c, w, "montecarlo", "gate", err, "", c->mc_gate);
  /* &flux gate not set in the file is &montecarlo's gate, checked there (de: check_registered) */
  if (c->nparams >= 0 && line_of(w, "flux", "gate") && !(c->flux_gate > 0 && c->flux_gate < DBL_MAX))
    n += bad(path, c, w, "flux", "gate", err, "", c->flux_gate);
  n += validate_scan(path, c, w, err);
  /* &flux order, n_cut, their ranges: check_registered */
  if (c->flux_order > 0 && in_registered_range(c, "flux", "order") && strcmp(c->system, "expression") &&
           !(!strcmp(c->system, "rolling_ball") && !strcmp(c->surface, "expression"))) {
    /* refused before the run samples the flux (tubes_expr_taylor's own check comes after it) */
    fprintf(err, "%s:%d: &flux: order = %d: the normal form needs the model written as a formula (&model system = "
            "'expression', or the ball's surface = 'expression'): its Taylor expansion comes from the formula; "
            "system '%s' is built in; allowed: order = 0 (docs/models.md)\n", path, line_or_group(w, "flux", "order"),
            c->flux_order, c->system);
    n++;
  }
  if (!in_registered_range(c, "experiment", "camera_rate"))
    ;   /* check_registered said so: the frames are not counted */
  else if (c->exp_duration > 0 && c->exp_duration * c->exp_camera_rate > 1e6)
    n += bad(path, c, w, "experiment", "camera_rate", err, "duration*camera_rate exceeds 1e6 frames per track",
             c->exp_camera_rate);
  else if (c->exp_duration > 0 && c->exp_n_tracks >= 1 &&
           (double)tubes_experiment_samples(c->exp_duration, c->exp_camera_rate) * c->exp_n_tracks > 5e7)
    n += bad(path, c, w, "experiment", "n_tracks", err, "n_tracks times the frames per track exceeds 5e7",
             c->exp_n_tracks);
  if (!(c->exp_de_min < c->exp_de_max))   /* the pair's rule; each one finite: check_registered */
    n += bad(path, c, w, "experiment", "de_min", err, "de_min must be below de_max", c->exp_de_min);
  if (!n) n += check_memory(path, c, w, err);
  return n;
}

static int load_into(const char *path, const char *out_override, tubes_config_t *cfg, nml_where *w,
                     FILE *err) {
  if (tubes_nml_config_size() != (int)sizeof *cfg) {   /* the generated struct against its definition */
    fprintf(err, "tubes: internal error: the settings' layout is %d bytes in Fortran (src/io/tubes_nml.f90) "
            "and %zu in C (build/include/tubes_config_fields.h): rebuild (make clean && make)\n",
            tubes_nml_config_size(), sizeof *cfg);
    return 1;
  }
  if (nml_lex(path, w, err)) return 1;
  int group = -1;
  char msg[512];
  int ios = tubes_nml_read(path, cfg, &group, msg, (int)sizeof msg);
  if (ios != 0) {
    if (group < 0) fprintf(err, "tubes: cannot read '%s': %s\n", path, msg);
    else nml_report_read_error(path, w, group, msg, err);
    return 1;
  }
  if (out_override) {
    if (strlen(out_override) >= TUBES_LPATH) {
      fprintf(err, "tubes: -o: file name longer than %d characters\n", TUBES_LPATH - 1);
      return 1;
    }
    snprintf(cfg->output, sizeof cfg->output, "%s", out_override);
  }
  return nml_validate(path, cfg, w, err) != 0;
}

/* The messages point at "FILE:LINE:", the line of the variable or of its group; a value the file
 * does not set at all (a default) has no line, and its messages say "FILE:" (not "FILE:0:"). */
int nml_load(const char *path, const char *out_override, tubes_config_t *cfg, nml_where *w,
             FILE *err) {
  char *buf = NULL;
  size_t len = 0;
  FILE *mem = open_memstream(&buf, &len);
  if (!mem) return load_into(path, out_override, cfg, w, err);
  int rc = load_into(path, out_override, cfg, w, mem);
  fclose(mem);
  size_t lp = strlen(path);
  for (const char *c = buf; c && *c;) {
    if (!strncmp(c, path, lp) && !strncmp(c + lp, ":0: ", 4)) {
      fprintf(err, "%s: ", path);
      c += lp + 4;
    } else {
      fputc(*c++, err);
    }
  }
  free(buf);
  return rc;
}

int tubes_input_check(const char *path, tubes_config_t *cfg, char *msg, int msglen) {
  static nml_where w;
  char *buf = NULL;
  size_t len = 0;
  FILE *err = open_memstream(&buf, &len);
  if (!err) {
    snprintf(msg, (size_t)msglen, "cannot open a memory stream for the messages");
    return -1;
  }
  int rc = nml_load(path, NULL, cfg, &w, err);
  fclose(err);
  snprintf(msg, (size_t)msglen, "%s", buf ? buf : "");
  free(buf);
  return rc;
}

void nml_print_help(FILE *out) {
  const char *tn[] = {"real", "integer", "logical", "string"};
  fprintf(out, "Scenes (&run scenes = ...):\n");
  for (int j = 0; j < tubes_nscenes; j++) fprintf(out, "  %-12s %s\n", tubes_scene_names[j], tubes_scene_docs[j]);
  fprintf(out, "\nNamelist groups and variables (details: docs/input.md):\n");
  for (int gi = 0; gi < tubes_nml_ngroups; gi++) {
    fprintf(out, "  &%s\n", tubes_nml_groups[gi]);
    for (int i = 0; i < tubes_nml_nvars; i++) {
      const nml_var *v = &tubes_nml_vars[i];
      if (strcmp(v->group, tubes_nml_groups[gi])) continue;
      fprintf(out, "    %-14s %-8s [%s] default %s; %s\n", v->name, tn[v->type], v->units, v->deflt, v->doc);
    }
  }
}
