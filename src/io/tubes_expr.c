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
 * trust (docs/cluster.md "The model cache"): the builder records the library's SHA-256 beside it
 * (<name>.so.sha256, sha256sum's format); a library is loaded only from a cache directory others
 * cannot write (or a sticky one of the user's or root's), only if it and its record are the user's
 * or root's and writable by no one else, and only if the bytes opened hash to the record; dlopen
 * then loads that open file (/proc/self/fd), so what was checked is what runs. A library refused
 * is built anew (with a message), or the build's failure says why.
 * tools: the code generator and the compiler run in their own process group, their output read
 * through a pipe; the generator has a time limit (TUBES_CODEGEN_TIMEOUT, default 120 s), and a
 * signal that stops the program stops them too (tubes_expr_abort).
 * open: the library of a name, through the same check (the loader keeps it: no state here). */
#include "tubes.h"
#include "tubes_sha256.h"
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/types.h>
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

static void generator_id(char *buf, size_t n);
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

/* mkdir -p; the last directory (the cache) only the user's (0700) */
static int make_dirs(const char *path) {
  char p[PATH_MAX];
  snprintf(p, sizeof p, "%s", path);
  for (char *s = p + 1; *s; s++)
    if (*s == '/') {
      *s = 0;
      if (mkdir(p, 0777) && errno != EEXIST) return -1;
      *s = '/';
    }
  return mkdir(p, 0700) && errno != EEXIST ? -1 : 0;
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

#ifndef S_ISVTX
#define S_ISVTX 01000
#endif

/* What a signal handler must undo while a tool runs (tubes_expr_abort): the tool's process group
 * and the build directory with the files a build makes in it (their paths made beforehand: the
 * handler only calls kill, unlink and rmdir), and the build's lock file. One build runs at a time
 * in a process (the model's build in the reader, the jets' under jet_lock). */
#define TRACKED_FILES 5
static const char *const tracked_names[TRACKED_FILES] = {"model.spec", "model.c", "model.so", "model.so.sha256",
                                                         "taylor"};
static volatile sig_atomic_t g_child_pgid = 0;      /* the running tool's process group, or 0 */
static volatile sig_atomic_t g_have_dir = 0, g_have_lock = 0;
static char g_dir[PATH_MAX + 64], g_files[TRACKED_FILES][PATH_MAX + 96], g_lock[PATH_MAX + 80];

static void track_dir(const char *dir) {
  snprintf(g_dir, sizeof g_dir, "%s", dir);
  for (int i = 0; i < TRACKED_FILES; i++) snprintf(g_files[i], sizeof g_files[i], "%s/%s", dir, tracked_names[i]);
  g_have_dir = 1;
}

int tubes_expr_abort(void) {
  int had = g_child_pgid > 0;
  if (had) kill(-(pid_t)g_child_pgid, SIGKILL);
  if (g_have_dir) {
    for (int i = 0; i < TRACKED_FILES; i++) unlink(g_files[i]);
    rmdir(g_dir);
  }
  if (g_have_lock) unlink(g_lock);
  return had;
}

/* While a tool runs, SIGINT, SIGTERM and SIGHUP kill its process group before going on to the
 * handler the host had (the program's on_signal, Python's KeyboardInterrupt, or the default
 * action): the tool's own group does not get the terminal's Ctrl-C, so it is passed on here. A
 * signal the host ignores is left alone. */
#define FORWARDED 3
static const int forwarded[FORWARDED] = {SIGINT, SIGTERM, SIGHUP};
static struct sigaction g_prev[FORWARDED];
static volatile sig_atomic_t g_interrupted = 0;

static void on_host_signal(int sig, siginfo_t *info, void *ctx) {
  if (g_child_pgid > 0) kill(-(pid_t)g_child_pgid, SIGKILL);
  g_interrupted = sig;
  for (int i = 0; i < FORWARDED; i++) {
    if (forwarded[i] != sig) continue;
    const struct sigaction *o = &g_prev[i];
    if (o->sa_flags & SA_SIGINFO) {
      o->sa_sigaction(sig, info, ctx);
    } else if (o->sa_handler == SIG_DFL) {   /* the default: end the process by the signal */
      sigaction(sig, o, NULL);
      raise(sig);
    } else if (o->sa_handler != SIG_IGN) {
      o->sa_handler(sig);
    }
  }
}

/* Install (on = 1) or remove the forwarding above. */
static void forward_signals(int on) {
  for (int i = 0; i < FORWARDED; i++) {
    if (on) {
      struct sigaction sa;
      memset(&sa, 0, sizeof sa);
      sa.sa_sigaction = on_host_signal;
      sa.sa_flags = SA_SIGINFO;
      sigfillset(&sa.sa_mask);
      if (sigaction(forwarded[i], NULL, &g_prev[i]) == 0 && g_prev[i].sa_handler != SIG_IGN &&
          !((g_prev[i].sa_flags & SA_SIGINFO) && g_prev[i].sa_sigaction == on_host_signal))
        sigaction(forwarded[i], &sa, NULL);
    } else {
      struct sigaction cur;
      if (sigaction(forwarded[i], NULL, &cur) == 0 && (cur.sa_flags & SA_SIGINFO) && cur.sa_sigaction == on_host_signal)
        sigaction(forwarded[i], &g_prev[i], NULL);
    }
  }
}

/* The code generator's time limit [s]: TUBES_CODEGEN_TIMEOUT, else 120. 0, or -1 with the reason. */
static int codegen_timeout(double *seconds, char *msg, int lmsg) {
  const char *e = getenv("TUBES_CODEGEN_TIMEOUT");
  *seconds = 120;
  if (!e || !e[0]) return 0;
  char *end;
  double v = strtod(e, &end);
  if (end == e || *end || !isfinite(v) || v <= 0) {
    say(msg, lmsg, "TUBES_CODEGEN_TIMEOUT = '%s' is not a time: allowed a number of seconds > 0 (the code "
        "generator's time limit; unset: 120)", e);
    return -1;
  }
  *seconds = v;
  return 0;
}

/* The exit status of a tool that ended (st from waitpid): its code, 128 + the signal that ended
 * it, or -1 with errno = ENOENT when it could not be run (127, the shell's convention). */
static int tool_status(int st) {
  if (WIFEXITED(st)) return WEXITSTATUS(st) == 127 ? (errno = ENOENT, -1) : WEXITSTATUS(st);
  return 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
}

/* Run argv in its own process group with stdin from in (or /dev/null); its stdout and stderr are
 * read through a pipe into out (the first lout - 1 bytes; the rest is read and dropped). With
 * limit > 0 [s] the group is killed when the tool has not ended by then (*timed_out = 1). The
 * exit status (tool_status), or -1 with errno when it could not start. */
static int run(char *const argv[], const char *in, char *out, size_t lout, double limit, int *timed_out) {
  int p[2];
  out[0] = 0;
  *timed_out = 0;
  if (pipe(p)) return -1;
  fcntl(p[0], F_SETFD, FD_CLOEXEC);
  fcntl(p[1], F_SETFD, FD_CLOEXEC);
  posix_spawn_file_actions_t fa;
  posix_spawnattr_t at;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, in ? in : "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&fa, p[1], 1);
  posix_spawn_file_actions_adddup2(&fa, p[1], 2);
  posix_spawnattr_init(&at);
  posix_spawnattr_setpgroup(&at, 0);              /* its own group: killed as one */
  sigset_t none, dfl;                             /* the tool starts with default signal handling */
  sigemptyset(&none);
  sigfillset(&dfl);
  sigdelset(&dfl, SIGKILL);
  sigdelset(&dfl, SIGSTOP);
  posix_spawnattr_setsigmask(&at, &none);
  posix_spawnattr_setsigdefault(&at, &dfl);
  posix_spawnattr_setflags(&at, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  pid_t pid;
  g_interrupted = 0;
  forward_signals(1);
  int e = posix_spawnp(&pid, argv[0], &fa, &at, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&at);
  close(p[1]);
  if (e) {
    forward_signals(0);
    close(p[0]);
    errno = e;
    return -1;
  }
  g_child_pgid = pid;
  if (g_interrupted) kill(-pid, SIGKILL);          /* a signal came while it started */
  double deadline = limit > 0 ? now() + limit : 0;
  size_t n = 0;
  char drop[4096];
  int st = 0, open_pipe = 1;
  for (;;) {
    double left = deadline > 0 ? deadline - now() : 1;
    if (left <= 0) {                                /* past its time: the whole group goes */
      kill(-pid, SIGKILL);
      *timed_out = 1;
      while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {}
      break;
    }
    if (!open_pipe) {                               /* its output closed: wait for its end */
      pid_t w = waitpid(pid, &st, deadline > 0 ? WNOHANG : 0);
      if (w == pid) break;
      if (w < 0 && errno != EINTR) break;
      struct timespec ts = {0, 10000000};
      nanosleep(&ts, NULL);
      continue;
    }
    struct pollfd pf = {p[0], POLLIN, 0};
    int r = poll(&pf, 1, deadline > 0 ? (left < 60 ? (int)(left * 1000) + 1 : 60000) : -1);
    if (r <= 0) continue;                           /* EINTR or the deadline: looked at above */
    ssize_t k = n + 1 < lout ? read(p[0], out + n, lout - 1 - n) : read(p[0], drop, sizeof drop);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) {
      open_pipe = 0;
      continue;
    }
    if (n + 1 < lout) {
      n += (size_t)k;
      out[n] = 0;
    }
  }
  g_child_pgid = 0;
  forward_signals(0);
  close(p[0]);
  return tool_status(st);
}

/* A tool's output (its complaint) into msg after its current text, without trailing blanks. */
static void append_out(char *msg, int lmsg, const char *out) {
  size_t k = strlen(msg);
  snprintf(msg + k, (size_t)lmsg - k, "%s", out);
  for (size_t i = strlen(msg); i > k && (msg[i - 1] == '\n' || msg[i - 1] == ' '); i--) msg[i - 1] = 0;
}

/* The last line of a tool's output that is not blank (an exception's own line, after its
 * traceback), into buf. */
static void last_line(const char *out, char *buf, size_t n) {
  const char *end = out + strlen(out);
  while (end > out && (end[-1] == '\n' || end[-1] == ' ')) end--;
  const char *b = end;
  while (b > out && b[-1] != '\n') b--;
  snprintf(buf, n, "%.*s", (int)(end - b), b);
}

/* The formula of a spec (its "expr " line, shortened to fit a message) and the variable that
 * holds it (hamiltonian or height; "system" for a spec without one, a built-in model's jet). */
static void spec_formula(const char *spec, char *formula, size_t n, char *var, int lvar) {
  formula[0] = 0;
  const char *e = strstr(spec, "\nexpr ");
  if (e) {
    e += 6;
    size_t l = strcspn(e, "\n");
    snprintf(formula, n, "%.*s%s", (int)(l < 300 ? l : 300), e, l > 300 ? "..." : "");
  }
  if (var)
    snprintf(var, (size_t)lvar, "%s", !e ? "system" : strstr(spec, "\nkind surface") ? "height" : "hamiltonian");
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
  g_have_dir = 0;
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

/* Is a file or directory (sb) one this program may trust: the user's or root's, and writable by
 * no one else? 0, or -1 with the reason in why (what names it). */
static int owned_safely(const struct stat *sb, const char *what, char *why, int lwhy) {
  uid_t me = geteuid();
  if (sb->st_uid != me && sb->st_uid != 0) {
    say(why, lwhy, "%s is owned by uid %u, not by you (uid %u) or root", what, (unsigned)sb->st_uid, (unsigned)me);
    return -1;
  }
  if (sb->st_mode & (S_IWGRP | S_IWOTH)) {
    say(why, lwhy, "%s is writable by %s (mode %04o)", what, sb->st_mode & S_IWOTH ? "others" : "its group",
        (unsigned)(sb->st_mode & 07777));
    return -1;
  }
  return 0;
}

/* The cache directory, checked: the user's or root's, and writable by no one else unless it is
 * sticky (as /tmp: others cannot then remove or replace what is yours). 0, or -1 with the
 * reason in msg. */
static int cache_dir_trusted(const char *dir, char *msg, int lmsg) {
  struct stat sb;
  const char *how = getenv("TUBES_CACHE_DIR") && getenv("TUBES_CACHE_DIR")[0] ? "TUBES_CACHE_DIR"
                                                                               : "the default; TUBES_CACHE_DIR sets another";
  if (stat(dir, &sb)) {
    say(msg, lmsg, "the model cache directory '%s' (%s): %s", dir, how, strerror(errno));
    return -1;
  }
  if (!S_ISDIR(sb.st_mode)) {
    say(msg, lmsg, "the model cache directory '%s' (%s) is not a directory", dir, how);
    return -1;
  }
  uid_t me = geteuid();
  if (sb.st_uid != me && sb.st_uid != 0) {
    say(msg, lmsg, "the model cache directory '%s' (%s) is owned by uid %u: a library its owner puts there would "
        "run in this program; allowed a directory of yours (uid %u) or root's", dir, how, (unsigned)sb.st_uid,
        (unsigned)me);
    return -1;
  }
  if ((sb.st_mode & (S_IWGRP | S_IWOTH)) && !(sb.st_mode & S_ISVTX)) {
    say(msg, lmsg, "the model cache directory '%s' (%s) is writable by %s (mode %04o) and not sticky: a library "
        "another user puts there would run in this program; allowed a directory only you can write (chmod 700 "
        "or 755), or a sticky one (chmod 1777, as /tmp; docs/cluster.md)", dir, how,
        sb.st_mode & S_IWOTH ? "others" : "its group", (unsigned)(sb.st_mode & 07777));
    return -1;
  }
  return 0;
}

/* The recorded SHA-256 of the library at path (path.sha256, written by the process that built
 * it) into hex; 0, or -1 with the reason in why. */
static int recorded_hash(const char *path, char hex[65], char *why, int lwhy) {
  char rec[PATH_MAX + 96], line[160];
  snprintf(rec, sizeof rec, "%s.sha256", path);
  int fd = open(rec, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    say(why, lwhy, "its recorded hash '%s' cannot be read (%s)", rec, strerror(errno));
    return -1;
  }
  struct stat sb;
  char what[PATH_MAX + 128];
  snprintf(what, sizeof what, "its recorded hash '%s'", rec);
  if (fstat(fd, &sb) || !S_ISREG(sb.st_mode) || owned_safely(&sb, what, why, lwhy)) {
    if (!why[0]) say(why, lwhy, "%s is not a regular file", what);
    close(fd);
    return -1;
  }
  ssize_t n = read(fd, line, sizeof line - 1);
  close(fd);
  line[n > 0 ? n : 0] = 0;
  size_t k = strspn(line, "0123456789abcdef");
  if (k != 64) {
    say(why, lwhy, "%s is not a SHA-256", what);
    return -1;
  }
  snprintf(hex, 65, "%.64s", line);
  return 0;
}

/* The files loaded by load_trusted (their device and inode, and the handle). The loader knows a
 * library by the name it was opened with, /proc/self/fd/N: the descriptor N stays open as long as
 * its library (the life of the process), so that no other file is ever opened under that name;
 * a file loaded again is found here and costs no descriptor. */
#define LOADED_TABLE 256
static struct {
  dev_t dev;
  ino_t ino;
  void *h;
} loaded[LOADED_TABLE];
static int nloaded;
static pthread_mutex_t loaded_lock = PTHREAD_MUTEX_INITIALIZER;

/* The library at path loaded if it can be trusted (the file and its hash record the user's or
 * root's and writable by no one else, the bytes opened hashing to the record): the handle of
 * that very file (dlopen of /proc/self/fd/N: what was checked is what runs), or NULL with the
 * reason in why. The directory is checked by the caller (cache_dir_trusted). */
static void *load_trusted(const char *path, char *why, int lwhy) {
  why[0] = 0;
  int fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    say(why, lwhy, "it cannot be opened (%s)", strerror(errno));
    return NULL;
  }
  struct stat sb;
  char want[65], got[65];
  void *h = NULL;
  if (fstat(fd, &sb) || !S_ISREG(sb.st_mode)) {
    say(why, lwhy, "it is not a regular file");
  } else if (!owned_safely(&sb, "it", why, lwhy) && !recorded_hash(path, want, why, lwhy)) {
    if (tubes_sha256_fd(fd, got)) {
      say(why, lwhy, "it cannot be read (%s)", strerror(errno));
    } else if (strcmp(got, want)) {
      say(why, lwhy, "its SHA-256 does not match the one recorded when it was built (a damaged or foreign file)");
    } else {
      pthread_mutex_lock(&loaded_lock);
      for (int i = 0; i < nloaded && !h; i++)
        if (loaded[i].dev == sb.st_dev && loaded[i].ino == sb.st_ino) h = loaded[i].h;
      if (h) {
        pthread_mutex_unlock(&loaded_lock);
        close(fd);
        return h;
      }
      char self[64];
      snprintf(self, sizeof self, "/proc/self/fd/%d", fd);
      h = dlopen(self, RTLD_NOW | RTLD_LOCAL);
      if (!h) {
        say(why, lwhy, "it cannot be loaded (%s)", dlerror());
      } else {
        if (nloaded < LOADED_TABLE) {
          loaded[nloaded].dev = sb.st_dev;
          loaded[nloaded].ino = sb.st_ino;
          loaded[nloaded].h = h;
          nloaded++;
        }
        fd = -1;                     /* kept: its number names the library (above) */
      }
      pthread_mutex_unlock(&loaded_lock);
    }
  }
  if (fd >= 0) close(fd);
  return h;
}

/* The library of a key in the cache, checked and loaded (load_trusted); NULL with the reason in
 * msg (the path named). */
static void *open_cached(const char key[TUBES_LSYSTEM], char *path, size_t lpath, char *msg, int lmsg) {
  char dir[PATH_MAX], k[TUBES_LSYSTEM + 1], why[1024];
  snprintf(k, sizeof k, "%.*s", TUBES_LSYSTEM, key);
  k[strcspn(k, " ")] = 0;
  path[0] = 0;
  if (strncmp(k, "expr_", 5) || cache_dir(dir, sizeof dir)) {
    say(msg, lmsg, "'%s' is not the name of a model written as a formula", k);
    return NULL;
  }
  snprintf(path, lpath, "%s/%s.so", dir, k);
  if (cache_dir_trusted(dir, msg, lmsg)) return NULL;
  void *h = load_trusted(path, why, (int)sizeof why);
  if (!h) say(msg, lmsg, "the cached library '%s' is refused: %s", path, why);
  return h;
}

/* Is the loaded library h the one of spec? (its embedded text) */
static int library_matches(const build_kind_t *bk, void *h, const char *spec) {
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
  /* the spec: the model, the compiler that builds it and the code generator (all in the hash: a
   * changed generator, one that now refuses a formula or prints it otherwise, builds anew) */
  const char *cc_env = getenv("TUBES_CC");
  char gen[512];
  generator_id(gen, sizeof gen);
  size_t ls = strlen(model) + 256 + sizeof gen;
  char *spec = malloc(ls);
  if (!spec) return TUBES_EIO;
  snprintf(spec, ls, "%scompiler %s %s\n%s\n", model, tubes_expr_compiler(), cc_env && cc_env[0] ? "" : TUBES_MODEL_CC_VERSION,
           gen);
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
  errno = 0;
  if (cache_dir(dir, sizeof dir) || make_dirs(dir) || !exists(dir, W_OK | X_OK)) {
    say(msg, lmsg, "the model cache directory '%s' cannot be created or written (%s): set TUBES_CACHE_DIR to a "
        "writable directory", dir, strerror(errno ? errno : EACCES));
    return TUBES_EIO;
  }
  if (cache_dir_trusted(dir, msg, lmsg)) return TUBES_EINPUT;
  snprintf(path, sizeof path, "%s/%s.so", dir, key);
  snprintf(lib, (size_t)llib, "%s", path);
  /* one build per library at a time, across processes (MPI ranks, runs started together): the
   * others wait for it and then load it. The lock file goes when its holder is done (a process
   * still waiting on it then holds the lock of a removed file and finds the library built; a
   * failed build may then be tried twice at once, which the private directory and the rename
   * keep safe) */
  snprintf(g_lock, sizeof g_lock, "%s/%s.lock", dir, key);
  int lockfd = open(g_lock, O_CREAT | O_RDWR | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (lockfd >= 0) {
    g_have_lock = 1;
    while (flock(lockfd, LOCK_EX) && errno == EINTR) {}
  }
  int rc0 = build_locked(bk, spec, var, lvar, msg, lmsg, path, dir, key, hit);
  if (lockfd >= 0) {
    unlink(g_lock);
    g_have_lock = 0;
    close(lockfd);
  }
  return rc0;
}

/* The SHA-256 of the library built at so recorded in rec (sha256sum's format, naming the
 * library as name); 0, or -1 with the reason in msg. */
static int record_hash(const char *so, const char *rec, const char *name, char *msg, int lmsg) {
  char hex[65], text[128];
  int fd = open(so, O_RDONLY | O_CLOEXEC);
  if (fd < 0 || tubes_sha256_fd(fd, hex)) {
    say(msg, lmsg, "cannot read the library just built, '%s': %s", so, strerror(errno));
    if (fd >= 0) close(fd);
    return -1;
  }
  close(fd);
  snprintf(text, sizeof text, "%s  %s\n", hex, name);
  return write_file(rec, text, msg, lmsg);
}

static int build_locked(const build_kind_t *bk, const char *spec, char *var, int lvar, char *msg, int lmsg,
                        const char *path, const char *dir, const char *key, int *hit) {
  char tmp[PATH_MAX + 64], why[1024] = "";
  struct stat lb;
  const char *off = getenv("TUBES_NO_CODEGEN");
  int codegen_off = off && off[0];
  if (lstat(path, &lb) == 0) {     /* a cached library: loaded only if it is the one its builder recorded */
    void *h = load_trusted(path, why, (int)sizeof why);
    if (h && library_matches(bk, h, spec)) {
      *hit = 1;
      return TUBES_OK;
    }
    if (h) say(why, (int)sizeof why, "it is another model's (the same hash of a different text)");
    if (codegen_off) {
      say(msg, lmsg, "the cached library '%s' is refused: %s; and code generation is off (TUBES_NO_CODEGEN is set)",
          path, why);
      return TUBES_EINPUT;
    }
    fprintf(stderr, "tubes: the cached library '%s' is refused: %s; it is built anew\n", path, why);
  } else if (codegen_off) {
    say(msg, lmsg, "the model is not in the cache and code generation is off (TUBES_NO_CODEGEN is set)");
    return TUBES_EINPUT;
  }
  double limit;
  if (codegen_timeout(&limit, msg, lmsg)) return TUBES_EINPUT;
  snprintf(tmp, sizeof tmp, "%s/%s.XXXXXX", dir, key);
  if (!mkdtemp(tmp)) {
    say(msg, lmsg, "cannot create a build directory in '%s': %s", dir, strerror(errno));
    return TUBES_EIO;
  }
  track_dir(tmp);
  char f_spec[PATH_MAX + 80], f_c[PATH_MAX + 80], f_so[PATH_MAX + 80], f_rec[PATH_MAX + 96], rec[PATH_MAX + 96];
  snprintf(f_spec, sizeof f_spec, "%s/model.spec", tmp);
  snprintf(f_c, sizeof f_c, "%s/model.c", tmp);
  snprintf(f_so, sizeof f_so, "%s/model.so", tmp);
  snprintf(f_rec, sizeof f_rec, "%s/model.so.sha256", tmp);
  snprintf(rec, sizeof rec, "%s.sha256", path);
  static char out[16384];          /* a tool's output (one build at a time: see track_dir) */
  int rc = TUBES_EIO;
  if (write_file(f_spec, spec, msg, lmsg)) goto done;
  char py[PATH_MAX], script[PATH_MAX];
  codegen_tools(py, sizeof py, script, sizeof script);
  {
    char *argv[] = {py, script, (char *)bk->codegen_flag, f_c, NULL};
    int timed_out;
    int st = run(argv, f_spec, out, sizeof out, limit, &timed_out);
    if (timed_out) {
      char formula[512];
      spec_formula(spec, formula, sizeof formula, var, lvar);
      say(msg, lmsg, "generating the code of %s%s%s did not finish within %g s (TUBES_CODEGEN_TIMEOUT; unset: "
          "120): the generator (%s %s) was stopped; simplify the formula, or allow more time", formula[0] ? "'" : "",
          formula[0] ? formula : "the model", formula[0] ? "'" : "", limit, py, script);
      rc = TUBES_EINPUT;
      goto done;
    }
    if (g_interrupted) {
      say(msg, lmsg, "interrupted by a signal (%d): the code generator was stopped", (int)g_interrupted);
      goto done;
    }
    if (st < 0) {
      say(msg, lmsg, "a model written as a formula needs Python 3 with SymPy to generate its code: '%s' cannot be "
          "run (%s); run make deps, or set TUBES_PYTHON", py, strerror(errno));
      goto done;
    }
    char *tab = strchr(out, '\t');
    if (st == 1 && tab && tab < out + strcspn(out, "\n")) {   /* the formula: "variable<TAB>message" */
      out[strcspn(out, "\n")] = 0;
      *tab = 0;
      if (strcmp(out, "-") != 0)
        snprintf(var, (size_t)lvar, "%s", out);
      else {   /* not one variable's fault (codegen.main: an internal error): the formula's variable */
        char formula[512];
        spec_formula(spec, formula, sizeof formula, var, lvar);
      }
      say(msg, lmsg, "%s", tab + 1);
      rc = TUBES_EINPUT;
      goto done;
    }
    if (st != 0) {   /* the generator failed (a traceback: its last line says why, e.g. a full disk) */
      char last[1024];
      last_line(out, last, sizeof last);
      say(msg, lmsg, "generating the model's code failed (%s %s, exit %d): %s", py, script, st,
          last[0] ? last : "it said nothing");
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
    int timed_out;
    int st = run(argv, NULL, out, sizeof out, 0, &timed_out);
    if (g_interrupted) {
      say(msg, lmsg, "interrupted by a signal (%d): the compiler was stopped", (int)g_interrupted);
      goto done;
    }
    if (st < 0) {
      say(msg, lmsg, "a model written as a formula is compiled with the build's C compiler: '%s' cannot be run "
          "(%s); install it, or set TUBES_CC", cc, strerror(errno));
      goto done;
    }
    if (st != 0) {
      say(msg, lmsg, "compiling the model's code failed (%s, exit %d): ", cc, st);
      append_out(msg, lmsg, out);
      goto done;
    }
  }
  /* readable by all, writable by this user alone (whatever the umask), and its hash recorded;
   * the record goes into place first: a reader that meets the new record with the old library
   * refuses it (and builds), never loads a library the record does not name */
  if (chmod(f_so, 0644) || record_hash(f_so, f_rec, strrchr(path, '/') + 1, msg, lmsg)) {
    if (!msg[0]) say(msg, lmsg, "cannot set the mode of '%s': %s", f_so, strerror(errno));
    goto done;
  }
  if (rename(f_rec, rec) || rename(f_so, path)) {
    say(msg, lmsg, "cannot move the model's library into the cache '%s': %s", path, strerror(errno));
    goto done;
  }
  {
    void *h = load_trusted(path, why, (int)sizeof why);
    if (!h || !library_matches(bk, h, spec)) {
      say(msg, lmsg, "the library just built, '%s', cannot be used: %s", path,
          h ? "it does not carry the model's text" : why);
      goto done;
    }
  }
  rc = TUBES_OK;
done:
  remove_tree(tmp);
  return rc;
}

int tubes_expr_open(const char key[TUBES_LSYSTEM], tubes_expr_lib_t *m) {
  char path[PATH_MAX + 64], k[TUBES_LSYSTEM + 1], msg[2048];
  memset(m, 0, sizeof *m);
  snprintf(k, sizeof k, "%.*s", TUBES_LSYSTEM, key);
  k[strcspn(k, " ")] = 0;
  if (strncmp(k, "expr_", 5) || strlen(k) != 21) return TUBES_EINPUT;
  void *h = open_cached(key, path, sizeof path, msg, (int)sizeof msg);
  if (!h) {
    fprintf(stderr, "tubes: %s\n", msg);
    return TUBES_EINPUT;
  }
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
  void *h = open_cached(key, path, sizeof path, msg, lmsg);
  if (!h) return TUBES_EINPUT;
  const char *text = (const char *)dlsym(h, "tubes_expr_text");
  const int *ndof = (const int *)dlsym(h, "tubes_expr_ndof");
  const int *kind = (const int *)dlsym(h, "tubes_expr_kind");
  if (!text || !ndof || !kind) {
    say(msg, lmsg, "the model's library '%s' lacks its text, degrees of freedom or kind", path);
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
  track_dir(tmp);
  char f_spec[PATH_MAX + 80], f_out[PATH_MAX + 80];
  snprintf(f_spec, sizeof f_spec, "%s/model.spec", tmp);
  snprintf(f_out, sizeof f_out, "%s/taylor", tmp);
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
    static char out[16384];
    double limit;
    int timed_out;
    if (codegen_timeout(&limit, msg, lmsg)) {
      rc = TUBES_EINPUT;
      goto done;
    }
    int st = run(argv, f_spec, out, sizeof out, limit, &timed_out);
    if (timed_out) {
      char formula[512];
      spec_formula(text, formula, sizeof formula, NULL, 0);
      say(msg, lmsg, "the Taylor expansion of '%s' did not finish within %g s (TUBES_CODEGEN_TIMEOUT; unset: 120): "
          "the generator (%s %s --taylor) was stopped", formula, limit, py, script);
      goto done;
    }
    if (st != 0) {
      say(msg, lmsg, "the Taylor expansion of the formula failed (%s %s --taylor, exit %d): ", py, script, st);
      append_out(msg, lmsg, out);
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

/* The generator's identity for the cache keys of the models and the jets: a hash of
 * python/tubes/codegen.py and of jetgen.py beside it (a changed generator builds anew), and the
 * jets' compiler flags. */
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

/* The lanes' width for this processor: $TUBES_LANES if set (1, 2, 4 or 8: a forced width, for
 * tests and comparisons), else the doubles of its widest vector registers that the kernels'
 * -march=native can use: 8 with AVX-512F, 4 with AVX, 2 otherwise (SSE2, every x86-64); 4 on a
 * processor that is not x86 (a width the kernels' loops vectorise on 128- or 256-bit units).
 * TUBES_EINPUT with the reason in msg when TUBES_LANES is set to anything else. */
int tubes_jet_lanes_default(char *msg, int lmsg) {
  msg[0] = 0;
  const char *env = getenv("TUBES_LANES");
  if (env && env[0]) {
    char *end;
    long w = strtol(env, &end, 10);
    if (*end || (w != 1 && w != 2 && w != 4 && w != 8)) {
      static int said;               /* on stderr once: the ensembles' items fail with TUBES_EINPUT */
      say(msg, lmsg, "TUBES_LANES='%s': the lanes' width must be 1, 2, 4 or 8 (unset: from the processor)", env);
      pthread_mutex_lock(&jet_lock);
      if (!said) fprintf(stderr, "taylor: %s\n", msg);
      said = 1;
      pthread_mutex_unlock(&jet_lock);
      return TUBES_EINPUT;
    }
    return (int)w;
  }
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) return 8;
  if (__builtin_cpu_supports("avx")) return 4;
  return 2;
#else
  return 4;
#endif
}

/* The lanes' driver's builds (src/integrators/tubes_lanes_run.f90, the Makefile): the library's
 * own, and for x86-64 the levels v3 (AVX2, FMA; its vectors 4 doubles) and v4 (AVX-512: 8). */
static const char *const lanes_driver_names[3] = {
#if defined(__x86_64__)
    "x86-64",
#else
    "generic",
#endif
    "x86-64-v3", "x86-64-v4"};

const char *tubes_lanes_driver_name(int d) { return d >= 0 && d <= 2 ? lanes_driver_names[d] : "none"; }

/* Can this processor run the lanes' driver's build d? (On another architecture than x86-64 the
 * builds 1 and 2 are the same code as 0, and never chosen by default.) */
static int lanes_driver_runs(int d) {
  if (d == 0) return 1;
#if defined(__x86_64__)
  __builtin_cpu_init();
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 12
  if (d == 1) return __builtin_cpu_supports("x86-64-v3") != 0;
  if (d == 2) return __builtin_cpu_supports("x86-64-v4") != 0;
#else  /* compilers without the levels' names (clang 14): their vector features (every processor
        * with these also has the levels' F16C, LZCNT and MOVBE) */
  int v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
           __builtin_cpu_supports("bmi2");
  if (d == 1) return v3;
  if (d == 2)
    return v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl");
#endif
#endif
  return 0;
}

/* tubes_lanes_driver without its message on stderr (free of jet_lock) */
static int lanes_driver_pick(int forced, char *msg, int lmsg) {
  msg[0] = 0;
  int widest = 2, d = forced;
  while (widest > 0 && !lanes_driver_runs(widest)) widest--;
  const char *env = getenv("TUBES_LANES_DRIVER");
  if (d < 0 && env && env[0]) {
    for (int i = 0; i < 3; i++)
      if (!strcmp(env, lanes_driver_names[i])) d = i;
    if (d < 0)
      say(msg, lmsg, "TUBES_LANES_DRIVER='%s': the lanes' driver must be %s, %s or %s (unset: the processor's widest)",
          env, lanes_driver_names[0], lanes_driver_names[1], lanes_driver_names[2]);
  } else if (d < 0) {
    return widest;
  }
  if (d >= 0 && (d > 2 || !lanes_driver_runs(d))) {
    say(msg, lmsg, "the lanes' driver %s: this processor lacks its instructions (its widest: %s)",
        tubes_lanes_driver_name(d), tubes_lanes_driver_name(widest));
    d = -1;
  }
  return d >= 0 ? d : TUBES_EINPUT;
}

int tubes_lanes_driver(int forced, char *msg, int lmsg) {
  int d = lanes_driver_pick(forced, msg, lmsg);
  if (d >= 0) return d;
  static int said;               /* on stderr once: the ensembles' items fail with TUBES_EINPUT */
  pthread_mutex_lock(&jet_lock);
  if (!said) fprintf(stderr, "taylor: %s\n", msg);
  said = 1;
  pthread_mutex_unlock(&jet_lock);
  return TUBES_EINPUT;
}

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
        fprintf(stderr, "taylor: built the order-%d jet kernel (%d lane%s%s%s) in %.1f s: %s\n", order, lanes,
                lanes > 1 ? "s" : "", lanes > 1 ? "; the lanes' driver " : "",
                lanes > 1 ? tubes_lanes_driver_name(lanes_driver_pick(-1, (char[512]){0}, 512)) : "", now() - t0, lib);
      else
        fprintf(stderr, "taylor: built the%s%s%s jet kernel of any order in %.1f s: %s\n",
                (flags & TUBES_JET_VARIATIONAL) ? " variational" : "", (flags & TUBES_JET_TANGENT) ? " tangent" : "",
                (flags & TUBES_JET_ACTION) ? " action" : "", now() - t0, lib);
    }
    char why[1024];
    void *h = load_trusted(lib, why, (int)sizeof why);
    if (!h) {
      say(msg, lmsg, "the Taylor kernel '%s' is refused: %s", lib, why);
      rc = TUBES_EIO;
      goto out;
    }
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
  char msg[2048];
  void *h = open_cached(key, path, sizeof path, msg, (int)sizeof msg);
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

/* ---------------------------------------------------------------- a formula's constants as a
 * scan's parameter (docs/scan.md, "A formula's constant"): the library of the same spec with one
 * constant's value changed, built like any formula model (its own name and cache entry; the
 * generated code depends on the constants' values, which SymPy sees as numbers). */

/* The model lines of the spec embedded in library key (those before the compiler's line, the text
 * tubes_expr_build was given), malloc'ed; NULL if the library cannot be read. */
static char *model_spec(const char key[TUBES_LSYSTEM]) {
  char path[PATH_MAX + 64], msg[2048];
  void *h = open_cached(key, path, sizeof path, msg, (int)sizeof msg);
  const char *text = h ? (const char *)dlsym(h, MODEL_BUILD.text_symbol) : NULL;
  if (!text) return NULL;
  const char *end = text;
  while (*end && strncmp(end, "compiler ", 9)) {
    const char *e = strchr(end, '\n');
    end = e ? e + 1 : end + strlen(end);
  }
  size_t n = (size_t)(end - text);
  char *s = malloc(n + 1);
  if (!s) return NULL;
  memcpy(s, text, n);
  s[n] = 0;
  return s;
}

/* The line "constant <name> = <rhs>" of spec: its start, and *rhs, *rhs_end the value's text
 * (blanks trimmed); NULL if there is none. */
static const char *constant_line(const char *spec, const char *name, const char **rhs, const char **rhs_end) {
  size_t ln = strlen(name);
  for (const char *s = spec; *s;) {
    const char *e = strchr(s, '\n');
    if (!e) e = s + strlen(s);
    if (!strncmp(s, "constant ", 9)) {
      const char *p = s + 9;
      while (*p == ' ') p++;
      if (!strncmp(p, name, ln)) {
        const char *q = p + ln;
        while (*q == ' ') q++;
        if (*q == '=' && ln > 0) {
          q++;
          while (q < e && *q == ' ') q++;
          const char *r = e;
          while (r > q && (r[-1] == ' ' || r[-1] == '\r')) r--;
          *rhs = q;
          *rhs_end = r;
          return s;
        }
      }
    }
    s = *e ? e + 1 : e;
  }
  return NULL;
}

/* The rhs as a number: 0 and *value if the whole text is one (strtod's syntax), else 1. */
static int plain_number(const char *rhs, const char *end, double *value) {
  char buf[256], *stop;
  size_t n = (size_t)(end - rhs);
  if (n == 0 || n >= sizeof buf) return 1;
  memcpy(buf, rhs, n);
  buf[n] = 0;
  errno = 0;
  double v = strtod(buf, &stop);
  if (*stop || errno || !isfinite(v)) return 1;
  *value = v;
  return 0;
}

int tubes_expr_constant(const char key[TUBES_LSYSTEM], const char *name, double *value) {
  char *spec = model_spec(key);
  const char *rhs, *end;
  int rc = TUBES_EINPUT;
  if (spec && constant_line(spec, name, &rhs, &end)) rc = plain_number(rhs, end, value) ? 1 : TUBES_OK;
  free(spec);
  return rc;
}

int tubes_expr_constant_names(const char key[TUBES_LSYSTEM], char *buf, int len) {
  char *spec = model_spec(key);
  size_t n = 0;
  buf[0] = 0;
  if (!spec) return TUBES_EINPUT;
  for (const char *s = spec; *s;) {
    const char *e = strchr(s, '\n');
    if (!e) e = s + strlen(s);
    if (!strncmp(s, "constant ", 9)) {
      const char *p = s + 9, *q;
      while (*p == ' ') p++;
      for (q = p; q < e && *q != ' ' && *q != '='; q++) {}
      char name[128];
      const char *rhs, *rend;
      double v;
      snprintf(name, sizeof name, "%.*s", (int)(q - p), p);
      if (constant_line(spec, name, &rhs, &rend) && !plain_number(rhs, rend, &v) &&
          n + strlen(name) + 2 < (size_t)len)
        n += (size_t)snprintf(buf + n, (size_t)len - n, "%s%s", n ? " " : "", name);
    }
    s = *e ? e + 1 : e;
  }
  free(spec);
  return TUBES_OK;
}

int tubes_expr_with_constant(const char key[TUBES_LSYSTEM], const char *name, double value,
                             char newkey[TUBES_LSYSTEM], char *msg, int lmsg) {
  char *spec = model_spec(key);
  const char *rhs, *end, *line;
  if (msg && lmsg > 0) msg[0] = 0;
  if (!spec || !(line = constant_line(spec, name, &rhs, &end)) || !isfinite(value)) {
    if (msg) say(msg, lmsg, "model %.*s has no constant %s given as a number", TUBES_LSYSTEM, key, name);
    free(spec);
    return TUBES_EINPUT;
  }
  /* the shortest decimal that reads back as value (a file's 'a = 1.5' and Python's repr: the same
   * spec, the same library, where the value is written so) */
  char num[40];
  for (int p = 1; p <= 17; p++) {
    snprintf(num, sizeof num, "%.*g", p, value);
    if (strtod(num, NULL) == value) break;
  }
  const char *eol = strchr(rhs, '\n');
  if (!eol) eol = rhs + strlen(rhs);
  size_t ls = strlen(spec) + strlen(name) + sizeof num + 32;
  char *out = malloc(ls);
  if (!out) {
    free(spec);
    return TUBES_EIO;
  }
  snprintf(out, ls, "%.*sconstant %s = %s%s", (int)(line - spec), spec, name, num, eol);
  char var[64], lib[PATH_MAX + 64], m[4096];
  double secs;
  int hit;
  int rc = tubes_expr_build(out, newkey, var, (int)sizeof var, m, (int)sizeof m, lib, (int)sizeof lib, &secs, &hit);
  if (rc && msg) say(msg, lmsg, "%s = %s: %s", name, num, m);
  free(out);
  free(spec);
  return rc;
}
