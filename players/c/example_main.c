/* An example firmware loop for an ESP32 or RP2040 that drives the arm's bus itself: include
 * the header `keypose export c SEQ -o seq.h` wrote, read the present ticks once, then call
 * kp_player_step at the control rate; each step sends one Sync Write of every goal.
 *
 * The board's part is the three functions declared below (UART write, present positions,
 * microsecond clock): Arduino-ESP32's Serial1.write and micros(), the Pico SDK's
 * uart_write_blocking and time_us_32(), with the bus adapter's direction pin handled there.
 * Define KP_DYNAMIXEL for Dynamixel servos (Koch, OpenMANIPULATOR-X); Feetech STS otherwise. */
#include <stddef.h>
#include <stdint.h>

#include "keypose_bus.h"
#include "keypose_player.h"
#include "seq.h"

extern void board_uart_write(const uint8_t *bytes, size_t length);
extern int board_read_present(const uint8_t *ids, int32_t *ticks, uint8_t count);
extern uint32_t board_micros(void);

#define CONTROL_PERIOD_US 10000u /* 100 Hz */

static int sync_write(void *context, const uint8_t *ids, const int32_t *ticks, uint8_t count) {
    uint8_t packet[16 + 5 * KP_MAX_JOINTS];
    (void)context;
#ifdef KP_DYNAMIXEL
    size_t length = kp_dynamixel_sync_write(ids, ticks, count, packet, sizeof packet);
#else
    size_t length = kp_feetech_sync_write(ids, ticks, count, packet, sizeof packet);
#endif
    if (length == 0) return -1;
    board_uart_write(packet, length);
    return 0;
}

int keypose_play(void) {
    int32_t present[KP_MAX_JOINTS];
    kp_player player;
    if (board_read_present(kp_seq.ids, present, kp_seq.joints) != 0) return -1;
    if (kp_player_start(&player, &kp_seq, present, CONTROL_PERIOD_US, sync_write, NULL) != 0) {
        return -1;
    }
    uint32_t start = board_micros();
    uint32_t next = start;
    for (;;) {
        while ((int32_t)(board_micros() - next) < 0) {
        }
        int state = kp_player_step(&player, next - start);
        if (state <= 0) return state;
        next += CONTROL_PERIOD_US;
    }
}
