/* tubes: the program entry. Reads and validates the namelist, runs the scenes, writes the HDF5
 * file under a temporary name and renames it when complete. Exit codes: docs/usage.md. */
#define _XOPEN_SOURCE 700   /* realpath */
#include "tubes.h"
#include "tubes_h5.h"
#include "tubes_input.h"
#include "tubes_scenes.h"
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <sys/stat.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <time.h>
#ifdef TUBES_MPI
#include <mpi.h>
#endif
#ifdef _OPENMP
#include <omp.h>
#endif

#ifndef TUBES_VERSION
#define TUBES_VERSION "unknown"
#endif
#ifndef TUBES_GIT
#define TUBES_GIT "unknown"
#endif
#ifndef TUBES_COMPILER
#define TUBES_COMPILER "unknown"
#endif
#ifndef TUBES_FFLAGS
#define TUBES_FFLAGS "unknown"
#endif

static void usage(FILE *out) {
  fprintf(out,
          "usage: tubes [options] INPUT.nml\n"
          "Phase-space transport between potential wells (tube dynamics) in Hamiltonian systems: the\n"
          "built-in models (&model system, docs/models.md) or one written as a formula in the input.\n\n"
          "options:\n"
          "  -o FILE      write the HDF5 output to FILE (overrides &run output)\n"
          "  --check      validate INPUT.nml as the run does before its work, print the effective namelist, exit\n"
          "  --version    print the version and exit\n"
          "  -h, --help   this help\n\n"
          "exit codes: 0 success; 1 bad input or usage; 2 numerical failure (reported on stderr;\n"
          "the file is still written with the failure recorded); 3 output could not be written;\n"
          "4 partial: some orbits failed or lie past the end of their family (the rest is written);\n"
          "128 + N stopped by signal N (130 Ctrl-C, 141 a closed reader of stdout, 143 SIGTERM; no output file)\n\n");
}

/* MPI (docs/cluster.md): every rank runs the whole program on the same input; the ensembles
 * are shared out inside the numerics (src/parallel/tubes_par.f90). Rank 0 alone prints and writes the
 * output file; the other ranks write their copy into an in-memory scratch file and print
 * nothing (TUBES_MPI_VERBOSE=1 lets them print). */
static int g_rank = 0, g_nranks = 1;
static char g_tmp[TUBES_LPATH + 64];

/* Signals (docs/output.md "Exit codes and signals"). Every catchable signal whose default is to
 * end the program stops a run at once: the code generator or compiler running for a formula is
 * stopped with its build directory (tubes_expr_abort), the temporary output file is removed (so no
 * partial or corrupt file is left), one message says what happened, and the exit code is 128 +
 * the signal (SIGHUP 129, SIGINT 130, SIGPIPE 141, SIGTERM 143, ...). SIGPIPE is a closed reader
 * of standard output (./tubes in.nml | head). Once the finished file has been renamed into place
 * the message says "output complete: FILE". A signal the caller ignores (nohup) stays ignored.
 * The faults (SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGSYS) clean up the same way and then die
 * by their signal as before (a core dump where enabled), unless a runtime (a sanitizer) handles
 * them already. Only async-signal-safe calls in the
 * handler: write, unlink, kill, rmdir, sigaction, raise, _exit.
 * One exception: the first SIGINT or SIGTERM while the scenes run (one process, not under MPI)
 * asks the run to stop (tubes_cancel_request: the ensembles stop within one unit of work); the
 * scene it interrupted is dropped and the finished ones are kept in a file marked incomplete
 * (/@incomplete), exit 128 + the signal. A second signal stops at once as above. */
typedef struct {
  int sig;
  const char *name, *what;
} signal_name_t;
static const signal_name_t STOP_SIGNALS[] = {
    {SIGHUP, "SIGHUP", "hangup"}, {SIGINT, "SIGINT", "interrupted"}, {SIGQUIT, "SIGQUIT", "quit"},
    {SIGTERM, "SIGTERM", "terminated"}, {SIGALRM, "SIGALRM", "alarm clock"},
    {SIGUSR1, "SIGUSR1", "user signal 1"}, {SIGUSR2, "SIGUSR2", "user signal 2"},
    {SIGPIPE, "SIGPIPE", "standard output was closed: its reader went away"},
    {SIGXCPU, "SIGXCPU", "CPU time limit exceeded"}, {SIGXFSZ, "SIGXFSZ", "file size limit exceeded"},
    {SIGVTALRM, "SIGVTALRM", "virtual timer expired"}, {SIGPROF, "SIGPROF", "profiling timer expired"},
#ifdef SIGPOLL
    {SIGPOLL, "SIGPOLL", "I/O possible"},
#endif
#ifdef SIGPWR
    {SIGPWR, "SIGPWR", "power failure"},
#endif
#ifdef SIGSTKFLT
    {SIGSTKFLT, "SIGSTKFLT", "stack fault"},
#endif
};
static const signal_name_t FAULT_SIGNALS[] = {
    {SIGSEGV, "SIGSEGV", "crashed: segmentation fault"}, {SIGBUS, "SIGBUS", "crashed: bus error"},
    {SIGILL, "SIGILL", "crashed: illegal instruction"}, {SIGFPE, "SIGFPE", "crashed: arithmetic exception"},
    {SIGABRT, "SIGABRT", "aborted"}, {SIGSYS, "SIGSYS", "crashed: bad system call"},
};
#define NSTOP ((int)(sizeof STOP_SIGNALS / sizeof STOP_SIGNALS[0]))
#define NFAULT ((int)(sizeof FAULT_SIGNALS / sizeof FAULT_SIGNALS[0]))

/* The output file's state, for the handler: none yet; the temporary file g_tmp exists; being
 * closed and renamed to g_out (the handler finds which by unlinking g_tmp); complete (renamed). */
enum { OUT_NONE = 0, OUT_TMP = 1, OUT_COMMITTING = 2, OUT_COMPLETE = 3 };
static volatile sig_atomic_t g_out_state = OUT_NONE;
static char g_out[TUBES_LPATH + 64];

static void say_raw(const char *s) {
  ssize_t r = write(STDERR_FILENO, s, strlen(s));
  (void)r;
}

static volatile sig_atomic_t g_in_scenes = 0, g_stop_sig = 0;   /* the scenes run; the stopping signal */

static void on_signal(int sig) {
  const signal_name_t *n = NULL;
  int fault = 0;
  for (int i = 0; i < NSTOP; i++)
    if (STOP_SIGNALS[i].sig == sig) n = &STOP_SIGNALS[i];
  for (int i = 0; i < NFAULT; i++)
    if (FAULT_SIGNALS[i].sig == sig) n = &FAULT_SIGNALS[i], fault = 1;
  if ((sig == SIGINT || sig == SIGTERM) && g_in_scenes && !g_stop_sig && g_out_state == OUT_TMP) {
    g_stop_sig = sig;                /* stop after the current unit of work; keep the finished scenes */
    tubes_cancel_request();
    say_raw("\ntubes: stopped by ");
    say_raw(n->name);
    say_raw(" (");
    say_raw(n->what);
    say_raw("): ending the current scene; the finished scenes will be kept (send it again to stop at once, "
            "without output)\n");
    return;
  }
  int tool = tubes_expr_abort();     /* first: the code generator goes at once */
  int state = g_out_state, complete = state == OUT_COMPLETE;
  int removed = 0;
  if (state == OUT_TMP || state == OUT_COMMITTING) {
    removed = unlink(g_tmp) == 0;
    complete = state == OUT_COMMITTING && !removed && errno == ENOENT;   /* renamed already */
  }
  say_raw(fault ? "\ntubes: " : "\ntubes: stopped by ");
  say_raw(n ? n->name : "a signal");
  say_raw(" (");
  say_raw(n ? n->what : "?");
  say_raw(")");
  if (tool) say_raw("; the code generator was stopped and its build directory removed");
  if (complete) {
    say_raw("; output complete: ");
    say_raw(g_out);
    say_raw("\n");
  } else {
    say_raw(removed ? "; the temporary output file was removed, no output written\n" : "; no output written\n");
  }
  if (fault) {                       /* die by the signal, as without this handler */
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    raise(sig);
    return;
  }
  _exit(128 + sig);
}

/* The handler for every signal above that the caller does not ignore; for a fault only where
 * nothing else handles it (a sanitizer's or a debugger's runtime keeps its own report). */
static void catch_signals(void) {
  struct sigaction sa, old;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigfillset(&sa.sa_mask);           /* one handler at a time (a SIGPIPE from its own message waits) */
  for (int k = 0; k < NSTOP + NFAULT; k++) {
    int sig = k < NSTOP ? STOP_SIGNALS[k].sig : FAULT_SIGNALS[k - NSTOP].sig;
    if (sigaction(sig, NULL, &old)) continue;
    if (old.sa_handler == SIG_IGN && !(old.sa_flags & SA_SIGINFO)) continue;   /* nohup */
    if (k >= NSTOP && ((old.sa_flags & SA_SIGINFO) || old.sa_handler != SIG_DFL)) continue;
    sigaction(sig, &sa, NULL);
  }
}

static void io_failed_abort(void) {
#ifdef TUBES_MPI
  fprintf(stderr, "tubes: writing '%s' failed on rank 0; stopping all %d ranks; no output file was left\n",
          g_tmp, g_nranks);
  remove(g_tmp);
  MPI_Abort(MPI_COMM_WORLD, EXIT_IO);
#endif
}

/* The worst exit code over the ranks: EXIT_IO, else EXIT_NUMERIC, else the largest. */
static int agree(int r) {
#ifdef TUBES_MPI
  if (g_nranks > 1) {
    int in[2] = {r == EXIT_IO, r == EXIT_NUMERIC ? 1 : 0}, out[2] = {0, 0}, rmax = r;
    MPI_Allreduce(in, out, 2, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&r, &rmax, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return out[0] ? EXIT_IO : out[1] ? EXIT_NUMERIC : rmax;
  }
#endif
  return r;
}

static int run_main(int argc, char **argv);

/* path with its directory made canonical (the file itself need not exist): two names of one
 * file compare equal. 0 if its directory does not exist. */
static int canonical_path(const char *path, char *out, size_t n) {
  char dir[TUBES_LPATH + 2], real[PATH_MAX];
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  if (slash) {
    size_t len = (size_t)(slash - path);
    if (len >= sizeof dir) return 0;
    memcpy(dir, path, len);
    dir[len ? len : 1] = '\0';          /* "/name": the root */
    if (!len) dir[0] = '/';
  } else {
    strcpy(dir, ".");
  }
  struct stat sb;
  if (lstat(path, &sb) == 0 && S_ISLNK(sb.st_mode)) {   /* a link: the file it names */
    if (!realpath(path, real)) return 0;
    snprintf(out, n, "%s", real);
    return 1;
  }
  if (!realpath(dir, real)) return 0;
  snprintf(out, n, "%s/%s", strcmp(real, "/") ? real : "", base);
  return 1;
}

/* An output file (what: "the output" or "&experiment csv") that the run may write: not a
 * directory, FIFO, device or socket (the finished file is renamed over what is there, which
 * would replace it), and not the input file. 0, or the exit code with the reason on stderr. */
static int check_output(const char *path, const char *what, const char *input, int bad) {
  struct stat sb;
  if (stat(path, &sb) == 0 && !S_ISREG(sb.st_mode)) {
    fprintf(stderr, "tubes: %s '%s' is %s: give the name of a regular file (&run output or -o)\n", what, path,
            S_ISDIR(sb.st_mode) ? "a directory" : S_ISFIFO(sb.st_mode) ? "a FIFO"
            : S_ISCHR(sb.st_mode) || S_ISBLK(sb.st_mode) ? "a device" : "not a regular file");
    return bad;
  }
  char a[PATH_MAX + TUBES_LPATH], b[PATH_MAX + TUBES_LPATH];
  if (canonical_path(path, a, sizeof a) && canonical_path(input, b, sizeof b) && !strcmp(a, b)) {
    fprintf(stderr, "tubes: %s '%s' is the input file '%s': it would be overwritten; give another name\n",
            what, path, input);
    return EXIT_BADINPUT;
  }
  return 0;
}

/* The run's output files before any work: the HDF5 output and the synthetic experiment's CSV. */
static int check_outputs(const char *input, tubes_config_t *cfg, const nml_where *where) {
  struct stat lb;
  if (lstat(cfg->output, &lb) == 0 && S_ISLNK(lb.st_mode)) {   /* a link: write the file it names */
    char real[PATH_MAX];
    if (!realpath(cfg->output, real)) {
      fprintf(stderr, "tubes: the output '%s' is a symbolic link to nothing that exists: give the name of a "
              "regular file (&run output or -o)\n", cfg->output);
      return EXIT_IO;
    }
    size_t len = strlen(real);
    if (len >= sizeof cfg->output) {
      fprintf(stderr, "tubes: the output '%s' is a symbolic link to '%s', whose path is longer than %zu "
              "characters: give the name of a regular file (&run output or -o)\n", cfg->output, real,
              sizeof cfg->output - 1);
      return EXIT_IO;
    }
    memcpy(cfg->output, real, len + 1);
  }
  int rc = check_output(cfg->output, "the output", input, EXIT_IO);
  if (rc) return rc;
  int experiment = 0;
  for (int k = 0; k < TUBES_NSCENES; k++) experiment |= !strcmp(cfg->scenes[k], "synthetic_experiment");
  if (!experiment || !cfg->exp_csv[0]) return 0;
  int line = nml_line(where, "experiment", "csv");
  char where_s[TUBES_LPATH + 32];
  snprintf(where_s, sizeof where_s, "%s:%d: &experiment csv", input, line);
  char a[PATH_MAX + TUBES_LPATH], b[PATH_MAX + TUBES_LPATH];
  if (!canonical_path(cfg->exp_csv, a, sizeof a)) {
    fprintf(stderr, "%s = '%s': its directory does not exist\n", where_s, cfg->exp_csv);
    return EXIT_BADINPUT;
  }
  if (canonical_path(cfg->output, b, sizeof b) && !strcmp(a, b)) {
    fprintf(stderr, "%s = '%s' is the HDF5 output file: give the CSV another name\n", where_s, cfg->exp_csv);
    return EXIT_BADINPUT;
  }
  struct stat sb;
  if (stat(cfg->exp_csv, &sb) == 0 && !S_ISREG(sb.st_mode)) {
    fprintf(stderr, "%s = '%s' is not a regular file: give the name of one\n", where_s, cfg->exp_csv);
    return EXIT_BADINPUT;
  }
  if (canonical_path(input, b, sizeof b) && !strcmp(a, b)) {
    fprintf(stderr, "%s = '%s' is the input file: it would be overwritten; give another name\n", where_s,
            cfg->exp_csv);
    return EXIT_BADINPUT;
  }
  return 0;
}

int main(int argc, char **argv) {
  setvbuf(stdout, NULL, _IOLBF, 0);   /* whole lines: stdout and stderr do not interleave mid-line */
  /* HDF5's exit handler closes every file still open: after a close that failed (a full disk) it
   * walks a half-closed file and crashes (SIGSEGV in H5F__close_cb). Every file here is closed
   * (or discarded) explicitly, so the handler has nothing to do: switch it off. */
  H5dont_atexit();
  catch_signals();
#ifdef TUBES_MPI
  int provided = 0;
  if (MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    fprintf(stderr, "tubes: MPI_Init_thread failed\n");
    return EXIT_IO;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_nranks);
  const char *v = getenv("TUBES_MPI_VERBOSE");
  if (g_rank != 0 && !(v && v[0] == '1')) {
    /* silence this rank's messages (stdio only: fd 2 stays open for the runtime's own) */
    FILE *null = fopen("/dev/null", "w");
    if (null) {
      stdout = null;
      stderr = null;
    }
  }
  if (provided < MPI_THREAD_FUNNELED && g_rank == 0)
    fprintf(stderr, "tubes: warning: the MPI library provides thread level %d < MPI_THREAD_FUNNELED\n", provided);
#endif
  int rc = run_main(argc, argv);
#ifdef TUBES_MPI
  MPI_Finalize();
#endif
  return rc;
}

static int run_main(int argc, char **argv) {
  const char *input = NULL, *out_override = NULL;
  int check_only = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
      usage(stdout);
      nml_print_help(stdout);
      return 0;
    } else if (!strcmp(argv[i], "--version")) {
      printf("tubes %s (git %s, %s)\n", TUBES_VERSION, TUBES_GIT, TUBES_COMPILER);
      return 0;
    } else if (!strcmp(argv[i], "--check")) {
      check_only = 1;
    } else if (!strcmp(argv[i], "-o")) {
      if (i + 1 >= argc) {
        fprintf(stderr, "tubes: -o needs a file name\n");
        return EXIT_BADINPUT;
      }
      out_override = argv[++i];
    } else if (argv[i][0] == '-' && argv[i][1]) {
      fprintf(stderr, "tubes: unknown option '%s' (see tubes --help)\n", argv[i]);
      return EXIT_BADINPUT;
    } else if (input) {
      fprintf(stderr, "tubes: only one input file is allowed ('%s' and '%s')\n", input, argv[i]);
      return EXIT_BADINPUT;
    } else {
      input = argv[i];
    }
  }
  if (!input) {
    usage(stderr);
    fprintf(stderr, "tubes: no input file given\n");
    return EXIT_BADINPUT;
  }

  static nml_where where;
  static tubes_config_t cfg;
  if (nml_load(input, out_override, &cfg, &where, stderr)) return EXIT_BADINPUT;
  /* the Taylor method's lanes' width (TUBES_LANES, else the processor's): recorded in the output
   * file; an invalid TUBES_LANES stops the run here (tubes_jet_lanes_default says why on stderr) */
  char lanes_msg[512];
  int lanes = tubes_jet_lanes_default(lanes_msg, (int)sizeof lanes_msg);
  if (lanes < 0) return EXIT_BADINPUT;
  /* and the build of the lanes' driver (TUBES_LANES_DRIVER, else the processor's widest): recorded
   * too; one the processor cannot run, or an unknown name, stops the run here (said on stderr) */
  int lanes_driver = tubes_lanes_driver(-1, lanes_msg, (int)sizeof lanes_msg);
  if (lanes_driver < 0) return EXIT_BADINPUT;

  static char nml_text[65536];
  if (tubes_nml_write(&cfg, nml_text, (int)sizeof nml_text) < 0) {
    fprintf(stderr, "tubes: internal error: effective namelist does not fit its buffer\n");
    return EXIT_IO;
  }
  /* an output that could not be written, or would replace what it must not, fails only at the
   * end otherwise, after the work: checked before it (rank 0 alone looks at the file system) */
  {
    int rc = g_rank == 0 ? check_outputs(input, &cfg, &where) : 0;
    if (agree(rc)) return rc;
  }

  /* the model, the box and the saddle (a saddle that does not exist is bad input): before the
   * output file exists, so that a refused run leaves none */
  static tubes_run_t run;
  run.cfg = &cfg;
  run.input = input;
  run.eq_saddle_line = nml_line(&where, "equilibria", "saddle");
  run.orb_saddle_line = nml_line(&where, "orbits", "saddle");
  run.method_line = nml_line(&where, "integrator", "method");
  run.scenes_line = nml_line(&where, "run", "scenes");
  run.where = &where;
  run.sec_kind_line = nml_line(&where, "section", "kind");
  run.rank = g_rank;
  run.nranks = g_nranks;
  run.seeds = tubes_seed_stores_new();  /* what later scenes take from earlier ones: the
                                          equilibria, orbit families, tube seeds (include/tubes.h) */
  int setup = agree(run_setup(&run));
  if (setup || check_only) {        /* --check: valid is what the run would start on */
    tubes_seed_stores_free(run.seeds);
    if (!setup && g_rank == 0) printf("%s: valid\n%s", input, nml_text);
    return setup;
  }

  char *tmp = g_tmp;
  errno = 0;
  hid_t f = g_rank == 0 ? h5_create_tmp(cfg.output, tmp, sizeof g_tmp) : h5_create_scratch();
  int create_errno = errno;
  if (g_rank == 0 && f >= 0) {
    snprintf(g_out, sizeof g_out, "%s", cfg.output);
    g_out_state = OUT_TMP;
  }
  if (agree(f < 0 ? EXIT_IO : 0) == EXIT_IO) {
    g_out_state = OUT_NONE;
    if (f >= 0) h5_discard(f, g_rank == 0 ? tmp : "");
    if (g_rank == 0)
      fprintf(stderr, "tubes: cannot create output file '%s' (via '%s'): %s\n", cfg.output, tmp,
              create_errno ? strerror(create_errno) : "HDF5 refused it");
    else
      fprintf(stderr, "tubes: rank %d cannot create its in-memory scratch file\n", g_rank);
    tubes_seed_stores_free(run.seeds);
    return EXIT_IO;
  }
  if (g_nranks > 1 && g_rank == 0) h5_set_failure_hook(io_failed_abort);
  h5_set_dimensionless(strcmp(run.length_units, "cm") != 0);
  char created[64], cmd[4096] = "";
  time_t tt = time(NULL);
  strftime(created, sizeof created, "%Y-%m-%dT%H:%M:%SZ", gmtime(&tt));
  for (int i = 0; i < argc; i++) {
    strncat(cmd, argv[i], sizeof cmd - strlen(cmd) - 2);
    if (i + 1 < argc) strncat(cmd, " ", sizeof cmd - strlen(cmd) - 1);
  }
  int rc = 0;
  rc |= h5_attr_string(f, "tubes_version", TUBES_VERSION);
  rc |= h5_attr_string(f, "git_commit", TUBES_GIT);
  rc |= h5_attr_string(f, "created", created);
  rc |= h5_attr_string(f, "input_file", input);
  rc |= h5_attr_string(f, "input_namelist", nml_text);
  rc |= h5_attr_string(f, "command_line", cmd);
  rc |= h5_attr_string(f, "compiler", TUBES_COMPILER);
  rc |= h5_attr_string(f, "fflags", TUBES_FFLAGS);
  rc |= h5_attr_long(f, "mpi_ranks", g_nranks);
  rc |= h5_attr_long(f, "taylor_lanes", lanes);
  rc |= h5_attr_string(f, "taylor_lanes_driver", tubes_lanes_driver_name(lanes_driver));
#ifdef _OPENMP
  rc |= h5_attr_long(f, "omp_threads", omp_get_max_threads());
#else
  rc |= h5_attr_long(f, "omp_threads", 1);
#endif
  if (rc) {
    fprintf(stderr, "tubes: cannot write to '%s'\n", tmp);
    g_out_state = OUT_NONE;
    h5_discard(f, tmp);
    tubes_seed_stores_free(run.seeds);
    return EXIT_IO;
  }

  run.file = f;
  int status = agree(scene_model(&run));
  int model_ok = status == 0;          /* no scene of a model that failed */
  char before[4096], done[TUBES_NSCENES * 32] = "";
  const char *stopped_in = NULL;       /* the scene a signal stopped (or had not started) */
  int started = 0;
  g_in_scenes = g_nranks == 1;         /* a signal now may keep the finished scenes (on_signal) */
  for (int k = 0; k < TUBES_NSCENES && model_ok && status != EXIT_IO; k++) {
    const char *s = cfg.scenes[k];
    int r = 0;
    if (!s[0]) continue;
    if (g_stop_sig) {                  /* between two scenes: the next one is not started */
      stopped_in = s;
      break;
    }
    if (h5_root_links(f, before, sizeof before)) g_in_scenes = 0;   /* cannot tell its groups: stop at once */
    if (!strcmp(s, "equilibria")) r = scene_equilibria(&run);
    else if (!strcmp(s, "trajectory")) r = scene_trajectory(&run);
    else if (!strcmp(s, "orbits")) r = scene_orbits(&run);
    else if (!strcmp(s, "tubes")) r = scene_tubes(&run);
    else if (!strcmp(s, "transition")) r = scene_transition(&run);
    else if (!strcmp(s, "montecarlo")) r = scene_montecarlo(&run);
    else if (!strcmp(s, "sections")) r = scene_sections(&run);
    else if (!strcmp(s, "synthetic_experiment")) r = scene_synthetic_experiment(&run);
    else if (!strcmp(s, "flux")) r = scene_flux(&run);
    else if (!strcmp(s, "scan")) r = scene_scan(&run);
    if (g_stop_sig) {                  /* interrupted during s: what it wrote goes */
      stopped_in = s;
      started = 1;
      if (h5_drop_links_since(f, before)) status = EXIT_IO;
      break;
    }
    r = agree(r);
    if (r == EXIT_IO) status = EXIT_IO;
    else if (r == EXIT_NUMERIC || (r && !status)) status = r;
    snprintf(done + strlen(done), sizeof done - strlen(done), "%s%s", done[0] ? " " : "", s);
  }
  g_in_scenes = 0;
  int stop = g_stop_sig;
  if (stop && status != EXIT_IO && g_rank == 0 && stopped_in) {
    if (!done[0]) {
      fprintf(stderr, "tubes: no scene had finished (the scene '%s' was stopped); no output written\n", stopped_in);
      g_out_state = OUT_NONE;
      h5_discard(f, tmp);
      tubes_seed_stores_free(run.seeds);
      return 128 + stop;
    }
    char why[256];
    snprintf(why, sizeof why, "stopped by %s %s the scene '%s'", stop == SIGINT ? "SIGINT" : "SIGTERM",
             started ? "during" : "before", stopped_in);
    if (h5_attr_string(f, "incomplete", why) || h5_attr_string(f, "scenes_complete", done)) status = EXIT_IO;
    else status = 128 + stop;
  } else if (stop && status == 0) {
    status = 128 + stop;               /* the signal came after the last scene: the output is complete */
  }
  tubes_seed_stores_free(run.seeds);
  run.seeds = NULL;
  if (g_rank != 0) {                  /* the scratch copy is dropped */
    H5Fclose(f);
    return status;
  }
  if (status == EXIT_IO) {
    int e = errno;   /* the reason HDF5's write or close met, when it was the system's */
    fprintf(stderr, "tubes: writing '%s' failed%s%s; no output file was left\n", tmp, e ? ": " : "",
            e ? strerror(e) : "");
    g_out_state = OUT_NONE;
    h5_discard(f, tmp);
    return EXIT_IO;
  }
  if (status == EXIT_BADINPUT) {       /* a request the model cannot meet: no output (docs/usage.md) */
    g_out_state = OUT_NONE;
    h5_discard(f, tmp);
    return EXIT_BADINPUT;
  }
  h5_attr_long(f, "exit_status", status);
  errno = 0;
  g_out_state = OUT_COMMITTING;       /* a signal now: the handler finds whether the rename happened */
  int committed = h5_commit(f, tmp, cfg.output);
  int committed_errno = errno;
  g_out_state = committed == 0 ? OUT_COMPLETE : OUT_NONE;   /* renamed, or removed by h5_commit */
  if (committed != 0) {
    fprintf(stderr, "tubes: cannot rename '%s' to '%s': %s; no output file was left\n", tmp, cfg.output,
            committed_errno ? strerror(committed_errno) : "HDF5 could not close it");
    return EXIT_IO;
  }
  if (stop && stopped_in) {
    fprintf(stderr, "tubes: kept the finished scenes (%s) in %s, marked incomplete (/@incomplete: the scene "
            "'%s' was %s)\n", done, cfg.output, stopped_in, started ? "stopped and left out" : "not started");
    return status;
  }
  if (stop) {
    fprintf(stderr, "tubes: the signal came after the last scene: output complete: %s\n", cfg.output);
    return status;
  }
  printf("wrote %s\n", cfg.output);
  return status;
}
