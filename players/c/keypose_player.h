/* keypose's reference player: plays a sequence exported with `keypose export c SEQ -o seq.h`
 * on a microcontroller (ESP32, RP2040, ...) that drives the servo bus itself.
 *
 * The header holds the checked trajectory as pieces of time; in each piece every joint's goal
 * is a cubic in servo ticks (Q16.16 fixed point). The player eases in from the arm's present
 * ticks to the first pose (a smoothstep, as long as the joints' speed and acceleration limits
 * need), then plays the pieces; every goal is clamped to the joint's tick limits before it is
 * handed to the bus write, a function the application provides (a sync write of goal positions).
 * Integer arithmetic at run time; float only once, to size the approach.
 */
#ifndef KEYPOSE_PLAYER_H
#define KEYPOSE_PLAYER_H

#include <stdint.h>

#define KP_MAX_JOINTS 16

typedef struct kp_sequence {
    uint8_t joints;
    uint16_t pieces;
    uint32_t duration_us;
    const uint8_t *ids;           /* servo id of each joint */
    const int32_t *tick_min;      /* every goal is clamped to [tick_min, tick_max] */
    const int32_t *tick_max;
    const float *max_speed;       /* ticks/s, ticks/s^2: bounds of the approach */
    const float *max_accel;
    const uint32_t *piece_start_us;
    const uint32_t *piece_duration_us;
    const int32_t *coefficients;  /* [piece][joint][4], Q16.16 ticks in u = (t - start)/duration */
} kp_sequence;

/* Writes one goal per joint (ids and ticks in joint order); returns 0 on success. */
typedef int (*kp_bus_write)(void *context, const uint8_t *ids, const int32_t *ticks, uint8_t count);

typedef struct kp_player {
    const kp_sequence *sequence;
    kp_bus_write write;
    void *context;
    int32_t from[KP_MAX_JOINTS];  /* present ticks when the player started */
    uint32_t approach_us;
} kp_player;

/* The sequence's goal ticks `t_us` after its start (held at both ends), clamped. */
void kp_sample(const kp_sequence *sequence, uint32_t t_us, int32_t *ticks);

/* Prepares playback from the arm's present ticks; returns 0, or -1 when the sequence has more
 * joints than KP_MAX_JOINTS. */
int kp_player_start(kp_player *player, const kp_sequence *sequence, const int32_t *present,
                    kp_bus_write write, void *context);

/* The goals `t_us` after kp_player_start (approach, then the sequence) into `ticks`. */
void kp_player_goals(const kp_player *player, uint32_t t_us, int32_t *ticks);

/* Computes and writes the goals for `t_us`; returns 1 while playing, 0 once the end is
 * written, a negative value when the bus write failed (its result). Call at the control rate. */
int kp_player_step(kp_player *player, uint32_t t_us);

#endif
