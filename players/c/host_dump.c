/* Prints the goals the player writes for a sequence at a control rate, as CSV rows
 * `time,tick,...` from the sequence's start to its end: what `keypose sample --units ticks`
 * prints for the same sequence. Build: gcc -I. -include seq.h host_dump.c keypose_player.c -lm
 * (tests/commands/export_c.rs does, on the host). With a second argument, the approach from the
 * ticks given there (comma-separated) is printed instead, until the first pose. How many goals
 * the step limiter changed goes to standard error (`limited N`). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "keypose_player.h"

static int print_goals(void *context, const uint8_t *ids, const int32_t *ticks, uint8_t count) {
    (void)ids;
    printf("%.9f", *(double *)context);
    for (uint8_t j = 0; j < count; j++) printf(",%d", (int)ticks[j]);
    printf("\n");
    return 0;
}

int main(int argc, char **argv) {
    double rate = argc > 1 ? atof(argv[1]) : 100.0;
    int32_t present[KP_MAX_JOINTS] = {0};
    int approach = argc > 2;
    if (approach) {
        char *text = argv[2];
        for (uint8_t j = 0; j < kp_seq.joints && text; j++) {
            present[j] = (int32_t)strtol(text, &text, 10);
            if (*text == ',') text++;
        }
    } else {
        kp_sample(&kp_seq, 0, present); /* already at the first pose: no approach */
    }
    kp_player player;
    double t = 0.0;
    uint32_t period_us = (uint32_t)(1e6 / rate + 0.5);
    if (kp_player_start(&player, &kp_seq, present, period_us, print_goals, &t) != 0) return 2;
    uint32_t from = approach ? 0 : player.approach_us;
    uint32_t until = approach ? player.approach_us : player.approach_us + kp_seq.duration_us;
    uint32_t last = from;
    for (unsigned long k = 0;; k++) {
        uint32_t t_us = from + (uint32_t)((double)k * 1e6 / rate + 0.5);
        if (t_us > until) break;
        t = (double)(t_us - from) / 1e6;
        kp_player_step(&player, t_us);
        last = t_us;
    }
    if (approach && last != until) { /* the approach's end, off the grid */
        t = (double)(until - from) / 1e6;
        kp_player_step(&player, until);
    }
    fprintf(stderr, "limited %u\n", (unsigned)player.limited);
    return 0;
}
