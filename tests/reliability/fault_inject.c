/*
 * Fault injection for the reliability tests, loaded with LD_PRELOAD into `pardel`: when the new
 * name of a rename(2) ends with "/" $PARDEL_FAULT_RENAME, the process sleeps $PARDEL_FAULT_SLEEP_MS
 * milliseconds and then raises signal $PARDEL_FAULT_SIGNAL (0: none), before the rename or, with
 * PARDEL_FAULT_WHEN=after, after it. Every write of pardel ends in such a rename (temporary file,
 * then rename), so this kills or delays a process at an exact point of its output, without timing.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int matches(const char* path) {
  const char* target = getenv("PARDEL_FAULT_RENAME");
  if (!target || !*target || !path) return 0;
  const size_t n = strlen(path), m = strlen(target);
  return n > m && path[n - m - 1] == '/' && strcmp(path + n - m, target) == 0;
}

static void fault(void) {
  const char* ms = getenv("PARDEL_FAULT_SLEEP_MS");
  if (ms && atol(ms) > 0) {
    struct timespec t = {atol(ms) / 1000, (atol(ms) % 1000) * 1000000L};
    while (nanosleep(&t, &t) != 0) {
    }
  }
  const char* sig = getenv("PARDEL_FAULT_SIGNAL");
  if (sig && atoi(sig) > 0) raise(atoi(sig));
}

int rename(const char* from, const char* to) {
  static int (*real_rename)(const char*, const char*);
  if (!real_rename) real_rename = (int (*)(const char*, const char*))dlsym(RTLD_NEXT, "rename");
  const int hit = matches(to);
  const char* when = getenv("PARDEL_FAULT_WHEN");
  const int after = when && strcmp(when, "after") == 0;
  if (hit && !after) fault();
  const int result = real_rename(from, to);
  if (hit && after) fault();
  return result;
}
