/* keypose's reference player (see keypose_player.h). */
#include "keypose_player.h"

#include <math.h>

/* floor(x / 65536) for negative x too (>> of a negative value is implementation-defined). */
static int64_t shr16(int64_t x) {
    return x >= 0 ? x >> 16 : -((-x + 65535) >> 16);
}

static int32_t clamp_tick(const kp_sequence *s, uint8_t joint, int64_t tick) {
    if (tick < s->tick_min[joint]) return s->tick_min[joint];
    if (tick > s->tick_max[joint]) return s->tick_max[joint];
    return (int32_t)tick;
}

/* The last piece starting at or before t (binary search). */
static uint16_t piece_at(const kp_sequence *s, uint32_t t_us) {
    uint16_t lo = 0, hi = s->pieces;
    while (hi - lo > 1) {
        uint16_t mid = (uint16_t)((lo + hi) / 2);
        if (s->piece_start_us[mid] <= t_us) lo = mid; else hi = mid;
    }
    return lo;
}

void kp_sample(const kp_sequence *s, uint32_t t_us, int32_t *ticks) {
    uint16_t p = piece_at(s, t_us);
    uint32_t start = s->piece_start_us[p], duration = s->piece_duration_us[p];
    uint32_t elapsed = t_us > start ? t_us - start : 0;
    if (elapsed > duration) elapsed = duration;
    /* u in Q16.16, 0 ... 65536 */
    int64_t u = duration ? ((int64_t)elapsed << 16) / duration : 0;
    const int32_t *c = s->coefficients + (uint32_t)p * s->joints * 4;
    for (uint8_t j = 0; j < s->joints; j++, c += 4) {
        int64_t acc = c[3];
        acc = shr16(acc * u) + c[2];
        acc = shr16(acc * u) + c[1];
        acc = shr16(acc * u) + c[0];
        ticks[j] = clamp_tick(s, j, shr16(acc + 32768)); /* nearest tick */
    }
}

/* Long enough that the smoothstep 3x^2 - 2x^3 over every joint's distance d keeps its peak
 * speed 1.5 d / T and peak acceleration 6 d / T^2 within the joint's limits. */
static uint32_t approach_duration(const kp_sequence *s, const int32_t *from, const int32_t *to) {
    float longest = 0.0f;
    for (uint8_t j = 0; j < s->joints; j++) {
        float d = fabsf((float)to[j] - (float)from[j]);
        float by_speed = s->max_speed[j] > 0.0f ? 1.5f * d / s->max_speed[j] : 0.0f;
        float by_accel = s->max_accel[j] > 0.0f ? sqrtf(6.0f * d / s->max_accel[j]) : 0.0f;
        if (by_speed > longest) longest = by_speed;
        if (by_accel > longest) longest = by_accel;
    }
    return (uint32_t)(longest * 1e6f) + 1u;
}

int kp_player_start(kp_player *player, const kp_sequence *s, const int32_t *present,
                    kp_bus_write write, void *context) {
    int32_t first[KP_MAX_JOINTS];
    if (s->joints > KP_MAX_JOINTS) return -1;
    player->sequence = s;
    player->write = write;
    player->context = context;
    kp_sample(s, 0, first);
    for (uint8_t j = 0; j < s->joints; j++) player->from[j] = clamp_tick(s, j, present[j]);
    player->approach_us = approach_duration(s, player->from, first);
    return 0;
}

void kp_player_goals(const kp_player *player, uint32_t t_us, int32_t *ticks) {
    const kp_sequence *s = player->sequence;
    if (t_us >= player->approach_us) {
        kp_sample(s, t_us - player->approach_us, ticks);
        return;
    }
    int32_t first[KP_MAX_JOINTS];
    kp_sample(s, 0, first);
    /* x in Q16.16; smoothstep 3x^2 - 2x^3 in Q16.16 */
    int64_t x = ((int64_t)t_us << 16) / player->approach_us;
    int64_t x2 = shr16(x * x);
    int64_t blend = 3 * x2 - 2 * shr16(x2 * x);
    for (uint8_t j = 0; j < s->joints; j++) {
        int64_t d = (int64_t)first[j] - player->from[j];
        ticks[j] = clamp_tick(s, j, player->from[j] + shr16(d * blend + 32768));
    }
}

int kp_player_step(kp_player *player, uint32_t t_us) {
    int32_t ticks[KP_MAX_JOINTS];
    const kp_sequence *s = player->sequence;
    kp_player_goals(player, t_us, ticks);
    int result = player->write(player->context, s->ids, ticks, s->joints);
    if (result != 0) return result < 0 ? result : -result;
    return t_us >= player->approach_us + s->duration_us ? 0 : 1;
}
