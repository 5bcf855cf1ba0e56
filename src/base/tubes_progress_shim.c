/* Progress of the long ensembles on stderr (docs/usage.md, "Progress"): the program's Monte Carlo
 * printed nothing between "integrating 4000000 points..." and its result 13 s later. ens_run
 * (src/parallel/tubes_ensemble.f90) calls tubes_progress_begin before its loop and
 * tubes_progress_tick as its units of work finish; a line is printed at most once a second and
 * only once the loop has run a second, with the count, the share, the time and an estimate of
 * the time left. Off unless the program turns it on (tubes_progress_enable): the library and
 * Python print nothing. Process-wide, as stderr is. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

static atomic_int enabled;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static double start, last;
static char what[32];

static double wall(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

void tubes_progress_enable(int on) { atomic_store(&enabled, on != 0); }

/* The items of a loop by its fault name (docs/development.md, "Fault injection"). */
static const char *noun(const char *fault, int len) {
  static const struct { const char *fault, *noun; } names[] = {
      {"sample", "points"}, {"seed", "tube seeds"}, {"map", "map trajectories"}, {"track", "tracks"},
      {"segment", "segments"}, {"scan", "parameter steps"}};
  for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
    if ((int)strlen(names[k].fault) == len && !strncmp(fault, names[k].fault, (size_t)len)) return names[k].noun;
  return "items";
}

void tubes_progress_begin(const char *fault, int len) {
  if (!atomic_load(&enabled)) return;
  pthread_mutex_lock(&lock);
  start = last = wall();
  snprintf(what, sizeof what, "%s", noun(fault, len));
  pthread_mutex_unlock(&lock);
}

/* A scene's own progress line (its step about to start: "sections: Poincare map at dE = 100 ..."),
 * printed at once, when progress lines are on: a scene's record holds its results, not these. */
void tubes_progress_line(const char *text, int len) {
  if (!atomic_load(&enabled)) return;
  pthread_mutex_lock(&lock);
  fprintf(stderr, "%.*s\n", len, text);
  pthread_mutex_unlock(&lock);
}

void tubes_progress_tick(long done, long total) {
  if (!atomic_load(&enabled) || pthread_mutex_trylock(&lock)) return;   /* another thread prints */
  double t = wall();
  if (t - last >= 1.0 && done > 0 && done < total) {
    last = t;
    double el = t - start, left = el * (double)(total - done) / (double)done;
    fprintf(stderr, "  %ld of %ld %s (%.0f%%), %.1f s, about %.0f s left\n", done, total, what,
            100.0 * (double)done / (double)total, el, left);
  }
  pthread_mutex_unlock(&lock);
}
