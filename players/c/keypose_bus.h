/* Sync Write packets of goal positions, for the player's bus write (keypose_player.h):
 * Feetech STS (instruction 0x83, Goal Position at 42, 2 bytes, sign in bit 15) and Dynamixel
 * Protocol 2.0 (instruction 0x83, Goal Position at 116, 4 bytes, CRC-16, byte stuffing);
 * docs/protocols.md §1 and §2. Each returns the packet's length in `out`, or 0 when it does
 * not fit `capacity`. */
#ifndef KEYPOSE_BUS_H
#define KEYPOSE_BUS_H

#include <stddef.h>
#include <stdint.h>

size_t kp_feetech_sync_write(const uint8_t *ids, const int32_t *ticks, uint8_t count,
                             uint8_t *out, size_t capacity);
size_t kp_dynamixel_sync_write(const uint8_t *ids, const int32_t *ticks, uint8_t count,
                               uint8_t *out, size_t capacity);

#endif
