/* Interrupting a call of the library (include/tubes.h, "Interrupting a call"): Python's Ctrl-C.
 * While the core computes, Python's own SIGINT handler only records the signal; the
 * KeyboardInterrupt came when the call ended (66 s after Ctrl-C on a 10^7-point Monte Carlo).
 * Between tubes_cancel_begin and tubes_cancel_end SIGINT sets the flag below instead, and the
 * ensemble layer (src/parallel/tubes_ensemble.f90) stops dealing out work when it is set. This is
 * the one piece of process-wide state of the library: a signal is process-wide. */
#include <signal.h>
#include <stdatomic.h>
#include <string.h>

#include "tubes.h"

static atomic_int requested;            /* SIGINT came since tubes_cancel_begin */
static struct sigaction saved;          /* the caller's SIGINT handler, restored by tubes_cancel_end */
static int installed;

static void on_sigint(int sig) {
  (void)sig;
  atomic_store(&requested, 1);          /* async-signal-safe: a lock-free atomic store */
}

void tubes_cancel_begin(void) {
  atomic_store(&requested, 0);
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  installed = sigaction(SIGINT, &sa, &saved) == 0;
}

int tubes_cancel_end(void) {
  if (installed) sigaction(SIGINT, &saved, NULL);
  installed = 0;
  int r = atomic_load(&requested);
  atomic_store(&requested, 0);
  return r;
}

int tubes_cancel_requested(void) { return atomic_load(&requested); }

/* From a signal handler of the program (src/io/tubes_main.c): the same flag, async-signal-safe. */
void tubes_cancel_request(void) { atomic_store(&requested, 1); }
