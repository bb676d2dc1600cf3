/* keypose's reference player: plays a sequence exported with `keypose export c SEQ -o seq.h`
 * on a microcontroller (ESP32, RP2040, ...) that drives the servo bus itself.
 *
 * The header holds the checked trajectory as pieces of time; in each piece every joint's goal
 * is a polynomial in servo ticks (Q16.16 fixed point): a cubic, or of a higher degree where a
 * segment has a timing profile (an eased or time-optimal segment). The player eases in from the arm's present
 * ticks to the first pose (a smoothstep, as long as the joints' speed and acceleration limits
 * need), then plays the pieces; every goal is clamped to the joint's tick limits and passed
 * through a step limiter before it is handed to the bus write, a function the application
 * provides (a sync write of goal positions). The limiter is keypose's (src/player/limiter.rs):
 * each step stays within v·T of zero and within a·T² of the previous step (T the control
 * period, v and a the joint's limits; after a late call the previous step counts at the rate
 * really followed, and an early call's step is its share of a period's), and slow enough to
 * stop before a tick limit. So a table sampled at another rate or phase than it was checked
 * for, or a hand-edited one, cannot command a jump.
 * Integer arithmetic at run time; float only at start, to size the approach and the limits.
 */
#ifndef KEYPOSE_PLAYER_H
#define KEYPOSE_PLAYER_H

#include <stdint.h>

#define KP_MAX_JOINTS 16

typedef struct kp_sequence {
    uint8_t joints;
    uint16_t pieces;
    uint8_t degree;               /* highest power of u: degree + 1 coefficients per joint and piece */
    uint32_t duration_us;
    const uint8_t *ids;           /* servo id of each joint */
    const int32_t *tick_min;      /* every goal is clamped to [tick_min, tick_max] */
    const int32_t *tick_max;
    const float *max_speed;       /* ticks/s, ticks/s^2: bounds of the approach */
    const float *max_accel;
    const uint32_t *piece_start_us;
    const uint32_t *piece_duration_us;
    const int32_t *coefficients;  /* [piece][joint][degree + 1], Q16.16 ticks in u = (t - start)/duration */
} kp_sequence;

/* Writes one goal per joint (ids and ticks in joint order); returns 0 on success. */
typedef int (*kp_bus_write)(void *context, const uint8_t *ids, const int32_t *ticks, uint8_t count);

typedef struct kp_player {
    const kp_sequence *sequence;
    kp_bus_write write;
    void *context;
    int32_t from[KP_MAX_JOINTS];  /* present ticks when the player started */
    uint32_t approach_us;
    /* The step limiter, in Q16.16 ticks: */
    uint32_t period_us;               /* T: kp_player_step is called every T */
    int64_t speed_step[KP_MAX_JOINTS];  /* v·T */
    int64_t accel_step[KP_MAX_JOINTS];  /* a·T² */
    int64_t last[KP_MAX_JOINTS];        /* the goal last written */
    int64_t last_step[KP_MAX_JOINTS];   /* and the step to it, per period */
    uint32_t last_us;                   /* when it was written */
    uint8_t started;                    /* a goal has been written */
    uint32_t limited;                   /* goals the limiter changed (0 in ordinary playback) */
} kp_player;

/* The sequence's goal ticks `t_us` after its start (held at both ends), clamped. */
void kp_sample(const kp_sequence *sequence, uint32_t t_us, int32_t *ticks);

/* Prepares playback from the arm's present ticks, for calls to kp_player_step every
 * `period_us` microseconds; returns 0, or -1 when the sequence has more joints than
 * KP_MAX_JOINTS or the period is 0. */
int kp_player_start(kp_player *player, const kp_sequence *sequence, const int32_t *present,
                    uint32_t period_us, kp_bus_write write, void *context);

/* The goals `t_us` after kp_player_start (approach, then the sequence) into `ticks`, clamped to
 * the tick limits but not through the step limiter. */
void kp_player_goals(const kp_player *player, uint32_t t_us, int32_t *ticks);

/* Computes the goals for `t_us`, limits their steps and writes them; returns 1 while playing,
 * 0 once the end is written (and the limiter has let it through), a negative value when the
 * bus write failed (its result). Call every period_us. */
int kp_player_step(kp_player *player, uint32_t t_us);

#endif
