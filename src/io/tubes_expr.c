/* Models written as formulas (docs/models.md, "Models from the input file"): the generated code's
 * shared library, built once and cached, then loaded (include/tubes.h: tubes_expr_build,
 * tubes_expr_open).
 *
 * build: the spec (src/io/tubes_nml.f90 writes it: the formula, names, constants and the
 * compiler) is hashed (FNV-1a, 64 bits) into the library's name expr_<hash>; a cache hit is a
 * library of that name whose embedded spec (tubes_expr_text) is the same text. A miss runs
 * python/tubes/codegen.py (SymPy) and the build's C compiler in a private temporary directory of
 * the cache and renames the library into place, so that runs and MPI ranks starting at once each
 * build or load a whole library, never a half-written one.
 * open: the library of a name, through dlopen (the loader keeps it: no state here). */
#include "tubes.h"
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#ifndef TUBES_MODEL_CC
#define TUBES_MODEL_CC "cc"
#endif
#ifndef TUBES_SOURCE_DIR
#define TUBES_SOURCE_DIR "."
#endif
#ifndef TUBES_MODEL_CC_VERSION
#define TUBES_MODEL_CC_VERSION ""
#endif
#define EXPR_CFLAGS "-O2", "-fPIC", "-shared", "-fno-math-errno"
/* Taylor jets (docs/integrators-taylor.md): for this machine's processor (its name and flags are
 * in the cache key); the kernels' fused multiply-adds are explicit (the same in every lane and for
 * one lane), nothing else is contracted */
#define JET_CFLAGS "-O2", "-march=native", "-ffp-contract=off", "-fPIC", "-shared", "-fno-math-errno"

/* What a build makes: a model's library (codegen.py --out) or a Taylor jet's (codegen.py --jet). */
typedef struct {
  const char *codegen_flag;   /* codegen.py's mode */
  const char *text_symbol;    /* the embedded spec, to tell a cached library from another's */
  const char *abi_symbol;
  char *const *cflags;        /* NULL-terminated */
} build_kind_t;
static char *const model_cflags[] = {EXPR_CFLAGS, NULL};
static char *const jet_cflags[] = {JET_CFLAGS, NULL};
static const build_kind_t MODEL_BUILD = {"--out", "tubes_expr_text", "tubes_expr_abi", model_cflags};
static const build_kind_t JET_BUILD = {"--jet", "tubes_jet_text", "tubes_jet_abi", jet_cflags};

static int build(const build_kind_t *bk, const char *spec, char key[TUBES_LSYSTEM], char *var, int lvar, char *msg,
                 int lmsg, char *lib, int llib, int *hit);
static int build_locked(const build_kind_t *bk, const char *spec, char *var, int lvar, char *msg, int lmsg,
                        const char *path, const char *dir, const char *key, int *hit);

static void say(char *msg, int lmsg, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, (size_t)lmsg, fmt, ap);
  va_end(ap);
}

/* The cache directory: $TUBES_CACHE_DIR, else ${XDG_CACHE_HOME:-$HOME/.cache}/tubes. */
static int cache_dir(char *buf, size_t n) {
  const char *d = getenv("TUBES_CACHE_DIR");
  if (d && d[0]) return snprintf(buf, n, "%s", d) >= (int)n ? -1 : 0;
  d = getenv("XDG_CACHE_HOME");
  if (d && d[0]) return snprintf(buf, n, "%s/tubes", d) >= (int)n ? -1 : 0;
  d = getenv("HOME");
  if (!d || !d[0]) d = "/tmp";
  return snprintf(buf, n, "%s/.cache/tubes", d) >= (int)n ? -1 : 0;
}

/* mkdir -p */
static int make_dirs(const char *path) {
  char p[PATH_MAX];
  snprintf(p, sizeof p, "%s", path);
  for (char *s = p + 1; *s; s++)
    if (*s == '/') {
      *s = 0;
      if (mkdir(p, 0777) && errno != EEXIST) return -1;
      *s = '/';
    }
  return mkdir(p, 0777) && errno != EEXIST ? -1 : 0;
}

static uint64_t fnv1a(const char *s) {
  uint64_t h = 1469598103934665603ULL;
  for (; *s; s++) h = (h ^ (unsigned char)*s) * 1099511628211ULL;
  return h;
}

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int exists(const char *path, int mode) { return access(path, mode) == 0; }

/* Run argv with stdin from in (or /dev/null) and stdout+stderr into out; the exit status, or -1
 * with errno when it could not start. */
static int run(char *const argv[], const char *in, const char *out) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, in ? in : "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, out, O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid;
  int e = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  if (e) {
    errno = e;
    return -1;
  }
  int st;
  while (waitpid(pid, &st, 0) < 0)
    if (errno != EINTR) return -1;
  if (WIFEXITED(st)) return WEXITSTATUS(st) == 127 ? (errno = ENOENT, -1) : WEXITSTATUS(st);
  return 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
}

/* The first lines of a file (a tool's complaint) into msg after its current text. */
static void append_file(char *msg, int lmsg, const char *path) {
  FILE *f = fopen(path, "r");
  if (!f) return;
  size_t k = strlen(msg);
  size_t n = fread(msg + k, 1, (size_t)lmsg - k - 1, f);
  msg[k + n] = 0;
  for (size_t i = k + n; i > k && (msg[i - 1] == '\n' || msg[i - 1] == ' '); i--) msg[i - 1] = 0;
  fclose(f);
}

/* rm -r of the build's temporary directory (flat) */
static void remove_tree(const char *dir) {
  DIR *d = opendir(dir);
  if (d) {
    struct dirent *e;
    char p[PATH_MAX + 512];
    while ((e = readdir(d)))
      if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
      }
    closedir(d);
  }
  rmdir(dir);
}

/* A tool: $ENV, else a path relative to the program's directory, else one relative to the
 * source tree the program was built from, else fallback (PATH). */
static void find_tool(char *buf, size_t n, const char *env, const char *rel, const char *fallback) {
  const char *e = getenv(env);
  if (e && e[0]) {
    snprintf(buf, n, "%s", e);
    return;
  }
  char exe[PATH_MAX];
  ssize_t k = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (k > 0) {
    exe[k] = 0;
    char *slash = strrchr(exe, '/');
    if (slash) {
      *slash = 0;
      if (snprintf(buf, n, "%s/%s", exe, rel) < (int)n && exists(buf, R_OK)) return;
    }
  }
  if (snprintf(buf, n, "%s/%s", TUBES_SOURCE_DIR, rel) < (int)n && exists(buf, R_OK)) return;
  snprintf(buf, n, "%s", fallback);
}

/* text into path; 0, or -1 with the file and the reason in msg. */
static int write_file(const char *path, const char *text, char *msg, int lmsg) {
  FILE *f = fopen(path, "w");
  int ok = f && fputs(text, f) >= 0;
  if (f && fclose(f)) ok = 0;
  if (!ok) say(msg, lmsg, "cannot write '%s': %s", path, strerror(errno));
  return ok ? 0 : -1;
}

/* The code generator's script (find_tool). */
static void codegen_script(char *script, size_t n) {
  find_tool(script, n, "TUBES_CODEGEN", "python/tubes/codegen.py", "codegen.py");
}

/* The Python that runs the code generator, and the generator. */
static void codegen_tools(char *py, size_t npy, char *script, size_t nscript) {
  find_tool(py, npy, "TUBES_PYTHON", ".venv/bin/python", "python3");
  codegen_script(script, nscript);
}

/* Is the library at path the model of spec? (its embedded text) */
static int library_matches(const build_kind_t *bk, const char *path, const char *spec) {
  void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!h) return 0;
  const char *text = (const char *)dlsym(h, bk->text_symbol);
  const int *abi = (const int *)dlsym(h, bk->abi_symbol);
  return text && abi && *abi == 1 && !strcmp(text, spec);
}

const char *tubes_expr_compiler(void) {
  const char *cc = getenv("TUBES_CC");
  return cc && cc[0] ? cc : TUBES_MODEL_CC;
}

int tubes_expr_build(const char *model, char key[TUBES_LSYSTEM], char *var, int lvar, char *msg, int lmsg,
                     char *lib, int llib, double *seconds, int *hit) {
  double t0 = now();
  /* the spec: the model and the compiler that builds it (both in the hash) */
  const char *cc_env = getenv("TUBES_CC");
  size_t ls = strlen(model) + 256;
  char *spec = malloc(ls);
  if (!spec) return TUBES_EIO;
  snprintf(spec, ls, "%scompiler %s %s\n", model, tubes_expr_compiler(), cc_env && cc_env[0] ? "" : TUBES_MODEL_CC_VERSION);
  int rc = build(&MODEL_BUILD, spec, key, var, lvar, msg, lmsg, lib, llib, hit);
  free(spec);
  *seconds = now() - t0;
  return rc;
}

static int build(const build_kind_t *bk, const char *spec, char key[TUBES_LSYSTEM], char *var, int lvar, char *msg,
                 int lmsg, char *lib, int llib, int *hit) {
  char dir[PATH_MAX], path[PATH_MAX + 64];
  *hit = 0;
  snprintf(var, (size_t)lvar, "system");
  msg[0] = 0;
  lib[0] = 0;
  snprintf(key, TUBES_LSYSTEM, "expr_%016llx", (unsigned long long)fnv1a(spec));
  if (cache_dir(dir, sizeof dir) || make_dirs(dir) || !exists(dir, W_OK | X_OK)) {
    say(msg, lmsg, "the model cache directory '%s' cannot be created or written (%s): set TUBES_CACHE_DIR to a "
        "writable directory", dir, strerror(errno ? errno : EACCES));
    return TUBES_EIO;
  }
  snprintf(path, sizeof path, "%s/%s.so", dir, key);
  snprintf(lib, (size_t)llib, "%s", path);
  /* one build per library at a time, across processes (MPI ranks, runs started together): the
   * others wait for it and then load it. The lock file goes when its holder is done (a process
   * still waiting on it then holds the lock of a removed file and finds the library built; a
   * failed build may then be tried twice at once, which the private directory and the rename
   * keep safe) */
  char lockpath[PATH_MAX + 80];
  snprintf(lockpath, sizeof lockpath, "%s/%s.lock", dir, key);
  int lockfd = open(lockpath, O_CREAT | O_RDWR, 0666);
  if (lockfd >= 0) while (flock(lockfd, LOCK_EX) && errno == EINTR) {}
  int rc0 = build_locked(bk, spec, var, lvar, msg, lmsg, path, dir, key, hit);
  if (lockfd >= 0) {
    unlink(lockpath);
    close(lockfd);
  }
  return rc0;
}

static int build_locked(const build_kind_t *bk, const char *spec, char *var, int lvar, char *msg, int lmsg,
                        const char *path, const char *dir, const char *key, int *hit) {
  char tmp[PATH_MAX + 64];
  if (exists(path, R_OK)) {
    if (library_matches(bk, path, spec)) {
      *hit = 1;
      return TUBES_OK;
    }
    say(msg, lmsg, "the cached library '%s' is not this model's (a damaged file, or another model with the same "
        "hash): remove it and run again", path);
    return TUBES_EIO;
  }
  const char *off = getenv("TUBES_NO_CODEGEN");
  if (off && off[0]) {
    say(msg, lmsg, "the model is not in the cache and code generation is off (TUBES_NO_CODEGEN is set)");
    return TUBES_EINPUT;
  }
  snprintf(tmp, sizeof tmp, "%s/%s.XXXXXX", dir, key);
  if (!mkdtemp(tmp)) {
    say(msg, lmsg, "cannot create a build directory in '%s': %s", dir, strerror(errno));
    return TUBES_EIO;
  }
  char f_spec[PATH_MAX + 80], f_c[PATH_MAX + 80], f_so[PATH_MAX + 80], f_log[PATH_MAX + 80];
  snprintf(f_spec, sizeof f_spec, "%s/model.spec", tmp);
  snprintf(f_c, sizeof f_c, "%s/model.c", tmp);
  snprintf(f_so, sizeof f_so, "%s/model.so", tmp);
  snprintf(f_log, sizeof f_log, "%s/log", tmp);
  int rc = TUBES_EIO;
  if (write_file(f_spec, spec, msg, lmsg)) goto done;
  char py[PATH_MAX], script[PATH_MAX];
  codegen_tools(py, sizeof py, script, sizeof script);
  {
    char *argv[] = {py, script, (char *)bk->codegen_flag, f_c, NULL};
    int st = run(argv, f_spec, f_log);
    if (st < 0) {
      say(msg, lmsg, "a model written as a formula needs Python 3 with SymPy to generate its code: '%s' cannot be "
          "run (%s); run make deps, or set TUBES_PYTHON", py, strerror(errno));
      goto done;
    }
    if (st == 1) {   /* the formula: "variable<TAB>message" */
      FILE *g = fopen(f_log, "r");
      char line[2048] = "";
      if (g && fgets(line, sizeof line, g)) {
        char *tab = strchr(line, '\t');
        line[strcspn(line, "\n")] = 0;
        if (tab) {
          *tab = 0;
          snprintf(var, (size_t)lvar, "%s", line);
          say(msg, lmsg, "%s", tab + 1);
        } else {
          say(msg, lmsg, "%s", line);
        }
      }
      if (g) fclose(g);
      rc = TUBES_EINPUT;
      goto done;
    }
    if (st != 0) {
      say(msg, lmsg, "generating the model's code failed (%s %s, exit %d): ", py, script, st);
      append_file(msg, lmsg, f_log);
      goto done;
    }
  }
  {
    char cc[PATH_MAX];
    snprintf(cc, sizeof cc, "%s", tubes_expr_compiler());
    char *argv[16] = {cc};
    int na = 1;
    for (char *const *f = bk->cflags; *f && na < 11; f++) argv[na++] = *f;
    argv[na++] = "-o";
    argv[na++] = f_so;
    argv[na++] = f_c;
    argv[na++] = "-lm";
    argv[na] = NULL;
    int st = run(argv, NULL, f_log);
    if (st < 0) {
      say(msg, lmsg, "a model written as a formula is compiled with the build's C compiler: '%s' cannot be run "
          "(%s); install it, or set TUBES_CC", cc, strerror(errno));
      goto done;
    }
    if (st != 0) {
      say(msg, lmsg, "compiling the model's code failed (%s, exit %d): ", cc, st);
      append_file(msg, lmsg, f_log);
      goto done;
    }
  }
  if (rename(f_so, path)) {
    say(msg, lmsg, "cannot move the model's library into the cache '%s': %s", path, strerror(errno));
    goto done;
  }
  if (!library_matches(bk, path, spec)) {
    say(msg, lmsg, "the library just built, '%s', cannot be loaded: %s", path, dlerror());
    goto done;
  }
  rc = TUBES_OK;
done:
  remove_tree(tmp);
  return rc;
}

int tubes_expr_open(const char key[TUBES_LSYSTEM], tubes_expr_lib_t *m) {
  char dir[PATH_MAX], path[PATH_MAX + 64], k[TUBES_LSYSTEM + 1];
  memset(m, 0, sizeof *m);
  snprintf(k, sizeof k, "%.*s", TUBES_LSYSTEM, key);
  k[strcspn(k, " ")] = 0;
  if (strncmp(k, "expr_", 5) || strlen(k) != 21 || cache_dir(dir, sizeof dir)) return TUBES_EINPUT;
  snprintf(path, sizeof path, "%s/%s.so", dir, k);
  void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!h) return TUBES_EINPUT;
  const int *abi = dlsym(h, "tubes_expr_abi"), *kind = dlsym(h, "tubes_expr_kind"),
            *ndof = dlsym(h, "tubes_expr_ndof"), *nat = dlsym(h, "tubes_expr_natural");
  const char *text = dlsym(h, "tubes_expr_text");
  if (!abi || *abi != 1 || !kind || !ndof || !nat || !text) return TUBES_EINPUT;
  const int *rev = dlsym(h, "tubes_expr_reversor");
  for (int i = 0; rev && i < 2 * *ndof && i < 2 * TUBES_MAXDOF; i++) m->reversor[i] = rev[i];
  m->kind = *kind;
  m->ndof = *ndof;
  m->natural = *nat;
  static const char *const ham[] = {"tubes_expr_energy", "tubes_expr_field", "tubes_expr_gradient",
                                    "tubes_expr_hessian", "tubes_expr_shape", "tubes_expr_shape_derivs",
                                    "tubes_expr_kinetic"};
  static const char *const surf[] = {"tubes_expr_height", "tubes_expr_derivs", "tubes_expr_third"};
  int nf = m->kind == 2 ? 3 : (m->natural ? 7 : 4);
  for (int i = 0; i < nf; i++) {
    *(void **)(&m->fn[i]) = dlsym(h, m->kind == 2 ? surf[i] : ham[i]);
    if (!m->fn[i]) return TUBES_EINPUT;
  }
  /* names and formula from the spec's lines */
  const char *s = text;
  while (*s) {
    const char *e = strchr(s, '\n');
    size_t n = e ? (size_t)(e - s) : strlen(s);
    if (!strncmp(s, "expr ", 5)) snprintf(m->formula, sizeof m->formula, "%.*s", (int)(n - 5), s + 5);
    int off = !strncmp(s, "coordinates ", 12) ? 0 : !strncmp(s, "momenta ", 8) ? TUBES_MAXDOF : -1;
    if (off >= 0) {
      const char *w = strchr(s, ' ') + 1;
      for (int j = 0; j < TUBES_MAXDOF && w < s + n; j++) {
        size_t l = strcspn(w, " \n");
        snprintf(m->names[off + j], sizeof m->names[0], "%.*s", (int)l, w);
        w += l;
        while (*w == ' ') w++;
      }
    }
    s += n + (e != NULL);
  }
  return TUBES_OK;
}

int tubes_expr_taylor(const char key[TUBES_LSYSTEM], const double *z, int order, int *n, int **expo, double **coef,
                      char *msg, int lmsg) {
  char dir[PATH_MAX], path[PATH_MAX + 64], k[TUBES_LSYSTEM + 1];
  *n = 0;
  *expo = NULL;
  *coef = NULL;
  msg[0] = 0;
  snprintf(k, sizeof k, "%.*s", TUBES_LSYSTEM, key);
  k[strcspn(k, " ")] = 0;
  if (strncmp(k, "expr_", 5) || cache_dir(dir, sizeof dir)) {
    say(msg, lmsg, "the normal form needs the model written as a formula (&model system = 'expression'): "
        "its Taylor expansion comes from the formula (docs/models.md)");
    return TUBES_EINPUT;
  }
  snprintf(path, sizeof path, "%s/%s.so", dir, k);
  void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  const char *text = h ? (const char *)dlsym(h, "tubes_expr_text") : NULL;
  const int *ndof = h ? (const int *)dlsym(h, "tubes_expr_ndof") : NULL;
  const int *kind = h ? (const int *)dlsym(h, "tubes_expr_kind") : NULL;
  if (!text || !ndof || !kind) {
    say(msg, lmsg, "cannot load the model's library '%s'", path);
    return TUBES_EINPUT;
  }
  if (*kind != 1) {
    say(msg, lmsg, "the normal form needs a Hamiltonian formula (system = 'expression'), not a surface");
    return TUBES_EINPUT;
  }
  int nv = 2 * *ndof;
  char tmp[PATH_MAX + 32];
  snprintf(tmp, sizeof tmp, "%s/taylor.XXXXXX", dir);
  if (!mkdtemp(tmp)) {
    say(msg, lmsg, "cannot create a directory in '%s': %s", dir, strerror(errno));
    return TUBES_EIO;
  }
  char f_spec[PATH_MAX + 80], f_out[PATH_MAX + 80], f_log[PATH_MAX + 80];
  snprintf(f_spec, sizeof f_spec, "%s/model.spec", tmp);
  snprintf(f_out, sizeof f_out, "%s/taylor", tmp);
  snprintf(f_log, sizeof f_log, "%s/log", tmp);
  int rc = TUBES_EIO;
  if (write_file(f_spec, text, msg, lmsg)) goto done;
  {
    char py[PATH_MAX], script[PATH_MAX], ord[16], zs[2 * TUBES_MAXDOF][32];
    codegen_tools(py, sizeof py, script, sizeof script);
    snprintf(ord, sizeof ord, "%d", order);
    char *argv[6 + 2 * TUBES_MAXDOF] = {py, script, "--taylor", f_out, ord};
    for (int i = 0; i < nv; i++) {
      snprintf(zs[i], sizeof zs[i], "%.17g", z[i]);
      argv[5 + i] = zs[i];
    }
    argv[5 + nv] = NULL;
    int st = run(argv, f_spec, f_log);
    if (st != 0) {
      say(msg, lmsg, "the Taylor expansion of the formula failed (%s %s --taylor, exit %d): ", py, script, st);
      append_file(msg, lmsg, f_log);
      goto done;
    }
  }
  {
    FILE *g = fopen(f_out, "r");
    if (!g) {
      say(msg, lmsg, "cannot read '%s': %s", f_out, strerror(errno));
      goto done;
    }
    int cap = 256, m = 0;
    int *e = malloc(sizeof(int) * (size_t)(cap * nv));
    double *c = malloc(sizeof(double) * (size_t)cap);
    int ok = e && c;
    while (ok) {
      int row[2 * TUBES_MAXDOF], got = 0;
      for (int i = 0; i < nv; i++) got += fscanf(g, "%d", &row[i]) == 1;
      double v;
      if (got != nv || fscanf(g, "%lf", &v) != 1) break;
      if (m == cap) {
        cap *= 2;
        int *e2 = realloc(e, sizeof(int) * (size_t)(cap * nv));
        double *c2 = realloc(c, sizeof(double) * (size_t)cap);
        if (e2) e = e2;
        if (c2) c = c2;
        ok = e2 && c2;
        if (!ok) break;
      }
      memcpy(e + (size_t)m * nv, row, sizeof(int) * (size_t)nv);
      c[m++] = v;
    }
    fclose(g);
    if (!ok) {
      free(e);
      free(c);
      say(msg, lmsg, "out of memory reading the Taylor expansion");
      goto done;
    }
    *n = m;
    *expo = e;
    *coef = c;
    rc = TUBES_OK;
  }
done:
  remove_tree(tmp);
  return rc;
}

/* ------------------------------------------------------------------ Taylor jets */

/* This processor, for the jets' cache key (they are built with -march=native): the model name and
 * a hash of the flags line of /proc/cpuinfo. */
static void cpu_id(char *buf, size_t n) {
  char line[4096], model[256] = "unknown";
  uint64_t flags = 0;
  FILE *f = fopen("/proc/cpuinfo", "r");
  while (f && fgets(line, sizeof line, f)) {
    char *colon = strchr(line, ':');
    if (!colon) continue;
    if (!strncmp(line, "model name", 10) && !strcmp(model, "unknown")) {
      snprintf(model, sizeof model, "%s", colon + 2);
      model[strcspn(model, "\n")] = 0;
    } else if (!strncmp(line, "flags", 5) && !flags) {
      flags = fnv1a(colon + 1);
    }
  }
  if (f) fclose(f);
  snprintf(buf, n, "%s %016llx", model, (unsigned long long)flags);
}

/* The generator's identity for the jets' cache key: a hash of python/tubes/codegen.py and of
 * jetgen.py beside it (a changed generator builds its kernels anew), and the compiler's flags. */
static void generator_id(char *buf, size_t n) {
  char script[PATH_MAX], path[PATH_MAX + 16];
  codegen_script(script, sizeof script);
  uint64_t h = 1469598103934665603ULL;
  for (int k = 0; k < 2; k++) {
    if (k == 0) {
      snprintf(path, sizeof path, "%s", script);
    } else {
      char *slash = strrchr(script, '/');
      snprintf(path, sizeof path, "%.*sjetgen.py", slash ? (int)(slash - script + 1) : 0, script);
    }
    FILE *f = fopen(path, "rb");
    int c;
    while (f && (c = fgetc(f)) != EOF) h = (h ^ (unsigned char)c) * 1099511628211ULL;
    if (f) fclose(f);
  }
  int m = snprintf(buf, n, "generator %016llx cflags", (unsigned long long)h);
  for (char *const *fl = jet_cflags; *fl && m > 0 && (size_t)m < n; fl++) m += snprintf(buf + m, n - (size_t)m, " %s", *fl);
}

/* The kernels loaded in this process: spec text -> function (one table, under a mutex; a
 * kernel, once loaded, stays for the life of the process, as its library does). */
#define JET_TABLE 256
typedef struct {
  char *model;               /* what was asked: the model's text, order, lanes, flags */
  int order, lanes, flags;
  tubes_jet_fn fn;           /* NULL: it could not be had (rc, msg): asked again, the same answer */
  int dim, nwork, rc;
  char *msg;
} jet_entry_t;
static jet_entry_t jet_table[JET_TABLE];
static int jet_count;
static pthread_mutex_t jet_lock = PTHREAD_MUTEX_INITIALIZER;

int tubes_jet_get(const char *model, int order, int lanes, int flags, tubes_jet_fn *fn, int *dim, int *nwork,
                  char *msg, int lmsg) {
  *fn = NULL;
  *dim = 0;
  *nwork = 0;
  msg[0] = 0;
  int var = flags != 0;   /* an extended state: the loop kernel of any order */
  if ((flags & ~(TUBES_JET_VARIATIONAL | TUBES_JET_ACTION | TUBES_JET_TANGENT)) ||
      ((flags & TUBES_JET_VARIATIONAL) && (flags & TUBES_JET_TANGENT)) || (var && (order != 0 || lanes != 1)) ||
      (!var && (order < 1 || order > 60 || (lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8)))) {
    say(msg, lmsg, "a Taylor jet of order %d for %d lanes, flags %d: orders 1 to 60 for lanes 1, 2, 4 or 8, or "
        "with flags order 0 (any order) and one lane", order, lanes, flags);
    return TUBES_EINPUT;
  }
  int rc = TUBES_OK;
  pthread_mutex_lock(&jet_lock);   /* asked before (the common case: every new integrator asks) */
  for (int i = 0; i < jet_count; i++)
    if (jet_table[i].order == order && jet_table[i].lanes == lanes && jet_table[i].flags == flags &&
        !strcmp(jet_table[i].model, model)) {
      *fn = jet_table[i].fn;
      *dim = jet_table[i].dim;
      *nwork = jet_table[i].nwork;
      rc = jet_table[i].rc;
      if (rc != TUBES_OK) say(msg, lmsg, "%s", jet_table[i].msg);
      pthread_mutex_unlock(&jet_lock);
      return rc;
    }
  pthread_mutex_unlock(&jet_lock);
  const char *cc_env = getenv("TUBES_CC");
  static char cpu[512], gen[512];   /* this processor and the generator: read once (under the lock) */
  char jet[96];
  pthread_mutex_lock(&jet_lock);
  if (!cpu[0]) cpu_id(cpu, sizeof cpu);
  if (!gen[0]) generator_id(gen, sizeof gen);
  pthread_mutex_unlock(&jet_lock);
  if (!var)
    snprintf(jet, sizeof jet, "jet order %d lanes %d\n", order, lanes);
  else
    snprintf(jet, sizeof jet, "jet loops%s%s%s\n", (flags & TUBES_JET_VARIATIONAL) ? " variational" : "",
             (flags & TUBES_JET_TANGENT) ? " tangent" : "", (flags & TUBES_JET_ACTION) ? " action" : "");
  size_t ls = strlen(model) + strlen(cpu) + strlen(gen) + 512;
  char *spec = malloc(ls);
  if (!spec) return TUBES_EIO;
  snprintf(spec, ls, "%s%scompiler %s %s\ncpu %s\n%s\n", model, jet, tubes_expr_compiler(),
           cc_env && cc_env[0] ? "" : TUBES_MODEL_CC_VERSION, cpu, gen);
  pthread_mutex_lock(&jet_lock);
  for (int i = 0; i < jet_count; i++)   /* another thread may have got it meanwhile */
    if (jet_table[i].order == order && jet_table[i].lanes == lanes && jet_table[i].flags == flags &&
        !strcmp(jet_table[i].model, model)) {
      *fn = jet_table[i].fn;
      *dim = jet_table[i].dim;
      *nwork = jet_table[i].nwork;
      rc = jet_table[i].rc;
      if (rc != TUBES_OK) say(msg, lmsg, "%s", jet_table[i].msg);
      goto out;
    }
  if (jet_count == JET_TABLE) {
    say(msg, lmsg, "more than %d Taylor kernels in one process", JET_TABLE);
    rc = TUBES_EINPUT;
    goto out;
  }
  {
    char key[TUBES_LSYSTEM], vname[64], lib[PATH_MAX + 64];
    int hit;
    double t0 = now();
    rc = build(&JET_BUILD, spec, key, vname, (int)sizeof vname, msg, lmsg, lib, (int)sizeof lib, &hit);
    if (rc != TUBES_OK) {            /* said once, remembered: a parallel loop asks many times */
      fprintf(stderr, "taylor: no kernel for the model: %s\n", msg);
      jet_table[jet_count] = (jet_entry_t){strdup(model), order, lanes, flags, NULL, 0, 0, rc, strdup(msg)};
      jet_count++;
      goto out;
    }
    if (!hit) {
      if (order > 0)
        fprintf(stderr, "taylor: built the order-%d jet kernel (%d lane%s) in %.1f s: %s\n", order, lanes,
                lanes > 1 ? "s" : "", now() - t0, lib);
      else
        fprintf(stderr, "taylor: built the%s%s%s jet kernel of any order in %.1f s: %s\n",
                (flags & TUBES_JET_VARIATIONAL) ? " variational" : "", (flags & TUBES_JET_TANGENT) ? " tangent" : "",
                (flags & TUBES_JET_ACTION) ? " action" : "", now() - t0, lib);
    }
    void *h = dlopen(lib, RTLD_NOW | RTLD_LOCAL);
    const int *d = h ? dlsym(h, "tubes_jet_dim") : NULL, *nw = h ? dlsym(h, "tubes_jet_nwork") : NULL;
    const int *o = h ? dlsym(h, "tubes_jet_order") : NULL, *l = h ? dlsym(h, "tubes_jet_lanes") : NULL;
    void *f = h ? dlsym(h, "tubes_jet") : NULL;
    if (!d || !nw || !o || !l || !f || *o != order || *l != (var ? 1 : lanes)) {
      say(msg, lmsg, "the Taylor kernel '%s' cannot be loaded or is not the one asked for", lib);
      rc = TUBES_EIO;
      goto out;
    }
    jet_table[jet_count].model = strdup(model);
    jet_table[jet_count].order = order;
    jet_table[jet_count].lanes = lanes;
    jet_table[jet_count].flags = flags;
    jet_table[jet_count].rc = TUBES_OK;
    *(void **)&jet_table[jet_count].fn = f;
    jet_table[jet_count].dim = *d;
    jet_table[jet_count].nwork = *nw;
    *fn = jet_table[jet_count].fn;
    *dim = *d;
    *nwork = *nw;
    jet_count++;
  }
out:
  pthread_mutex_unlock(&jet_lock);
  free(spec);
  return rc;
}

int tubes_expr_spec(const char key[TUBES_LSYSTEM], char *buf, int len) {
  char dir[PATH_MAX], path[PATH_MAX + 64], k[TUBES_LSYSTEM + 1];
  buf[0] = 0;
  snprintf(k, sizeof k, "%.*s", TUBES_LSYSTEM, key);
  k[strcspn(k, " ")] = 0;
  if (strncmp(k, "expr_", 5) || cache_dir(dir, sizeof dir)) return TUBES_EINPUT;
  snprintf(path, sizeof path, "%s/%s.so", dir, k);
  void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  const char *text = h ? (const char *)dlsym(h, "tubes_expr_text") : NULL;
  if (!text) return TUBES_EINPUT;
  /* the model's lines, without the compiler's (a jet adds its own) */
  size_t n = 0;
  for (const char *s = text; *s;) {
    const char *e = strchr(s, '\n');
    size_t l = e ? (size_t)(e - s) + 1 : strlen(s);
    if (strncmp(s, "compiler ", 9)) {
      if (n + l + 1 > (size_t)len) return TUBES_EINPUT;
      memcpy(buf + n, s, l);
      n += l;
    }
    s += l;
  }
  buf[n] = 0;
  return TUBES_OK;
}
