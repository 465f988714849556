/* How regularly this machine wakes any thread at 1 ms deadlines: the floor under stream.py.
 *
 * One thread sleeps to absolute 1 ms deadlines (CLOCK_MONOTONIC, 1 ns timer slack), as the
 * physics thread does, and records the time between consecutive wake-ups. No Python, no
 * sockets: a gap here is the machine's (another task, or the hypervisor not running the
 * vCPU), and no server can send more regularly than this.
 *
 *   cc -O2 -o /tmp/timer_floor benchmarks/timer_floor.c && /tmp/timer_floor 10000
 *   chrt -f 20 /tmp/timer_floor 10000     # under SCHED_FIFO, as --rt-priority 20 serves
 */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <time.h>

static double seconds(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int ascending(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    int n = argc > 1 ? atoi(argv[1]) : 10000;
    if (n < 1000) {
        fprintf(stderr, "usage: %s [wake-ups, at least 1000]\n", argv[0]);
        return 2;
    }
    double *gap_ms = malloc(sizeof(double) * (size_t)n);
    if (gap_ms == NULL)
        return 1;
    prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
    struct timespec deadline;
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    double last = seconds();
    int over_2ms = 0;
    for (int i = 0; i < n; i++) {
        deadline.tv_nsec += 1000000;
        if (deadline.tv_nsec >= 1000000000) {
            deadline.tv_nsec -= 1000000000;
            deadline.tv_sec += 1;
        }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, NULL);
        double now = seconds();
        gap_ms[i] = 1e3 * (now - last);
        over_2ms += gap_ms[i] > 2.0;
        last = now;
    }
    qsort(gap_ms, (size_t)n, sizeof(double), ascending);
    printf("%d wake-ups at 1 ms deadlines: interval p50 %.3f  p99 %.3f  p99.9 %.3f  max %.3f ms;"
           " %d over 2 ms\n", n, gap_ms[n / 2], gap_ms[n * 99 / 100], gap_ms[n * 999 / 1000],
           gap_ms[n - 1], over_2ms);
    free(gap_ms);
    return 0;
}
