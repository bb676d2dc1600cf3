/* keypose's reference player (see keypose_player.h). */
#include "keypose_player.h"

#include <math.h>

/* Slack of the step limiter's bands, Q16.16 ticks (1/1024 of a tick): the fixed-point polynomial's
 * rounding, far below what a servo resolves. */
#define KP_LIMIT_SLACK 64

/* floor(x / 65536) for negative x too (>> of a negative value is implementation-defined). */
static int64_t shr16(int64_t x) {
    return x >= 0 ? x >> 16 : -((-x + 65535) >> 16);
}

static int64_t min64(int64_t a, int64_t b) { return a < b ? a : b; }
static int64_t max64(int64_t a, int64_t b) { return a > b ? a : b; }

static int64_t tick_min_q16(const kp_sequence *s, uint8_t joint) {
    return (int64_t)s->tick_min[joint] * 65536;
}

static int64_t tick_max_q16(const kp_sequence *s, uint8_t joint) {
    return (int64_t)s->tick_max[joint] * 65536;
}

static int64_t clamp_q16(const kp_sequence *s, uint8_t joint, int64_t q) {
    return max64(tick_min_q16(s, joint), min64(q, tick_max_q16(s, joint)));
}

/* The nearest tick of a Q16.16 value, clamped. */
static int32_t to_tick(const kp_sequence *s, uint8_t joint, int64_t q) {
    return (int32_t)shr16(clamp_q16(s, joint, q) + 32768);
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

/* Joint `joint`'s goal `t_us` after the sequence's start (held at both ends), Q16.16 ticks,
 * clamped. */
static int64_t sample_q16(const kp_sequence *s, uint32_t t_us, uint8_t joint) {
    uint16_t p = piece_at(s, t_us);
    uint32_t start = s->piece_start_us[p], duration = s->piece_duration_us[p];
    uint32_t elapsed = t_us > start ? t_us - start : 0;
    if (elapsed > duration) elapsed = duration;
    /* u in Q16.16, 0 ... 65536 */
    int64_t u = duration ? ((int64_t)elapsed << 16) / duration : 0;
    uint32_t n = (uint32_t)s->degree + 1u;
    const int32_t *c = s->coefficients + ((uint32_t)p * s->joints + joint) * n;
    /* Horner: |acc| stays within the sum of the |c| (u <= 1), at most 256 * 2^31, so acc * u
     * stays within 2^56. */
    int64_t acc = c[s->degree];
    for (uint32_t k = s->degree; k-- > 0;) acc = shr16(acc * u) + c[k];
    return clamp_q16(s, joint, acc);
}

void kp_sample(const kp_sequence *s, uint32_t t_us, int32_t *ticks) {
    for (uint8_t j = 0; j < s->joints; j++) ticks[j] = to_tick(s, j, sample_q16(s, t_us, j));
}

/* Long enough that the smoothstep 3x^2 - 2x^3 over every joint's distance d keeps its peak
 * speed 1.5 d / T and peak acceleration 6 d / T^2 within the joint's limits. */
static uint32_t approach_duration(const kp_sequence *s, const int32_t *from) {
    float longest = 0.0f;
    for (uint8_t j = 0; j < s->joints; j++) {
        float d = fabsf((float)(sample_q16(s, 0, j) - (int64_t)from[j] * 65536) / 65536.0f);
        float by_speed = s->max_speed[j] > 0.0f ? 1.5f * d / s->max_speed[j] : 0.0f;
        float by_accel = s->max_accel[j] > 0.0f ? sqrtf(6.0f * d / s->max_accel[j]) : 0.0f;
        if (by_speed > longest) longest = by_speed;
        if (by_accel > longest) longest = by_accel;
    }
    return (uint32_t)(longest * 1e6f) + 1u;
}

int kp_player_start(kp_player *player, const kp_sequence *s, const int32_t *present,
                    uint32_t period_us, kp_bus_write write, void *context) {
    if (s->joints > KP_MAX_JOINTS || period_us == 0) return -1;
    player->sequence = s;
    player->write = write;
    player->context = context;
    player->period_us = period_us;
    float period = (float)period_us * 1e-6f;
    for (uint8_t j = 0; j < s->joints; j++) {
        int64_t held = clamp_q16(s, j, (int64_t)present[j] * 65536);
        player->from[j] = (int32_t)shr16(held);
        player->speed_step[j] = (int64_t)(s->max_speed[j] * period * 65536.0f);
        /* At least one unit: a band of zero width would hold the joint forever. */
        player->accel_step[j] = max64(1, (int64_t)(s->max_accel[j] * period * period * 65536.0f));
        player->last[j] = held;
        player->last_step[j] = 0;
    }
    player->approach_us = approach_duration(s, player->from);
    player->last_us = 0;
    player->started = 0;
    player->limited = 0;
    return 0;
}

/* The goals `t_us` after kp_player_start in Q16.16 ticks, clamped: a smoothstep from the
 * present ticks to the first pose, then the sequence. */
static void goals_q16(const kp_player *player, uint32_t t_us, int64_t *goal) {
    const kp_sequence *s = player->sequence;
    if (t_us >= player->approach_us) {
        for (uint8_t j = 0; j < s->joints; j++) {
            goal[j] = sample_q16(s, t_us - player->approach_us, j);
        }
        return;
    }
    /* x in Q16.16; smoothstep 3x^2 - 2x^3 in Q16.16 */
    int64_t x = ((int64_t)t_us << 16) / player->approach_us;
    int64_t x2 = shr16(x * x);
    int64_t blend = 3 * x2 - 2 * shr16(x2 * x);
    for (uint8_t j = 0; j < s->joints; j++) {
        int64_t from = (int64_t)player->from[j] * 65536;
        int64_t d = sample_q16(s, 0, j) - from;
        goal[j] = clamp_q16(s, j, from + shr16(d * blend));
    }
}

void kp_player_goals(const kp_player *player, uint32_t t_us, int32_t *ticks) {
    int64_t goal[KP_MAX_JOINTS];
    goals_q16(player, t_us, goal);
    for (uint8_t j = 0; j < player->sequence->joints; j++) {
        ticks[j] = to_tick(player->sequence, j, goal[j]);
    }
}

static uint64_t isqrt64(uint64_t x) {
    uint64_t root = 0, bit = (uint64_t)1 << 62;
    while (bit > x) bit >>= 2;
    while (bit) {
        if (x >= root + bit) {
            x -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    return root;
}

/* The largest step towards a limit `room` away after which the joint can still stop before it,
 * slowing by `a` per period (src/player/limiter.rs derives it): after a step s with
 * n·a <= s < (n+1)·a come s - a, ..., s - n·a, (n+1)·s - a·n(n+1)/2 in all. */
static int64_t stoppable_step(int64_t room, int64_t a) {
    if (room <= 0) return 0;
    int64_t n = ((int64_t)isqrt64((uint64_t)(1 + 8 * (room / a))) - 1) / 2;
    while (a * (n + 1) * (n + 2) / 2 <= room) n++;
    while (n > 0 && a * n * (n + 1) / 2 > room) n--;
    return min64((room + a * n * (n + 1) / 2) / (n + 1), (n + 1) * a);
}

/* Saturates each joint's step to `goal` (Q16.16) into what its limits allow from the previous
 * step, as keypose's player does (src/player/limiter.rs), and returns whether any goal changed.
 * Steps are compared per period: a call `gap` after the previous one moves min(gap, T)/T of a
 * period's step (an early call, after a late one, moves less), and after a late call the
 * previous step counts at the rate really followed, T/gap of it (the goal was held meanwhile). */
static int limit_steps(kp_player *player, uint32_t t_us, int64_t *goal) {
    const kp_sequence *s = player->sequence;
    int64_t period = player->period_us;
    int64_t gap = player->started ? (int64_t)(uint32_t)(t_us - player->last_us) : period;
    int64_t used = gap < period ? (gap > 0 ? gap : 1) : period;
    int changed = 0;
    for (uint8_t j = 0; j < s->joints; j++) {
        int64_t from = player->last[j];
        int64_t v = player->speed_step[j], a = player->accel_step[j];
        int64_t reference = gap > period ? player->last_step[j] * period / gap : player->last_step[j];
        int64_t low = max64(reference - a, -v) - KP_LIMIT_SLACK;
        int64_t high = min64(reference + a, v) + KP_LIMIT_SLACK;
        high = max64(min64(high, stoppable_step(tick_max_q16(s, j) - from, a)), low);
        low = min64(max64(low, -stoppable_step(from - tick_min_q16(s, j), a)), high);
        int64_t wanted = goal[j] - from;
        int64_t per_period = wanted * period / used;
        int64_t step = wanted;
        if (per_period < low || per_period > high) {
            step = max64(low, min64(per_period, high)) * used / period;
        }
        step = max64(tick_min_q16(s, j) - from, min64(step, tick_max_q16(s, j) - from));
        if (step != wanted) changed = 1;
        goal[j] = from + step;
        player->last[j] = goal[j];
        player->last_step[j] = step * period / used;
    }
    player->last_us = t_us;
    player->started = 1;
    if (changed) player->limited++;
    return changed;
}

int kp_player_step(kp_player *player, uint32_t t_us) {
    int64_t goal[KP_MAX_JOINTS];
    int32_t ticks[KP_MAX_JOINTS];
    const kp_sequence *s = player->sequence;
    goals_q16(player, t_us, goal);
    int changed = limit_steps(player, t_us, goal);
    for (uint8_t j = 0; j < s->joints; j++) ticks[j] = to_tick(s, j, goal[j]);
    int result = player->write(player->context, s->ids, ticks, s->joints);
    if (result != 0) return result < 0 ? result : -result;
    return t_us >= player->approach_us + s->duration_us && !changed ? 0 : 1;
}
