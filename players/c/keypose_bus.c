/* Sync Write packets of goal positions (see keypose_bus.h). */
#include "keypose_bus.h"

#define BROADCAST 0xFE
#define SYNC_WRITE 0x83
#define STS_GOAL_POSITION 42
#define DXL_GOAL_POSITION 116

size_t kp_feetech_sync_write(const uint8_t *ids, const int32_t *ticks, uint8_t count,
                             uint8_t *out, size_t capacity) {
    size_t params = 2 + 3u * count;
    size_t total = params + 6; /* FF FF ID LEN INST ... CHECKSUM */
    if (total > capacity || params + 2 > 255) return 0;
    size_t n = 0;
    out[n++] = 0xFF;
    out[n++] = 0xFF;
    out[n++] = BROADCAST;
    out[n++] = (uint8_t)(params + 2);
    out[n++] = SYNC_WRITE;
    out[n++] = STS_GOAL_POSITION;
    out[n++] = 2;
    for (uint8_t i = 0; i < count; i++) {
        /* Sign-magnitude: bit 15 is the sign. */
        int32_t t = ticks[i];
        uint16_t raw = t < 0 ? (uint16_t)(0x8000u | (uint16_t)(-t & 0x7FFF)) : (uint16_t)(t & 0x7FFF);
        out[n++] = ids[i];
        out[n++] = (uint8_t)(raw & 0xFF);
        out[n++] = (uint8_t)(raw >> 8);
    }
    uint8_t sum = 0;
    for (size_t k = 2; k < n; k++) sum = (uint8_t)(sum + out[k]);
    out[n++] = (uint8_t)~sum;
    return n;
}

/* CRC-16, polynomial 0x8005, no reflection, initial value 0, no final XOR (bit by bit). */
static uint16_t crc16(const uint8_t *data, size_t length) {
    uint16_t crc = 0;
    for (size_t i = 0; i < length; i++) {
        crc ^= (uint16_t)(data[i] << 8);
        for (int b = 0; b < 8; b++) crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x8005) : (uint16_t)(crc << 1);
    }
    return crc;
}

size_t kp_dynamixel_sync_write(const uint8_t *ids, const int32_t *ticks, uint8_t count,
                               uint8_t *out, size_t capacity) {
    uint8_t body[4 + 5 * 255];
    size_t b = 0;
    body[b++] = SYNC_WRITE;
    body[b++] = DXL_GOAL_POSITION;
    body[b++] = 0;
    body[b++] = 4;
    body[b++] = 0;
    for (uint8_t i = 0; i < count; i++) {
        uint32_t raw = (uint32_t)ticks[i]; /* two's complement, little-endian */
        body[b++] = ids[i];
        for (int k = 0; k < 4; k++) body[b++] = (uint8_t)(raw >> (8 * k));
    }
    /* Header, ID, LEN (2), then the body with FD inserted after every FF FF FD, then CRC. */
    size_t n = 7;
    if (capacity < n) return 0;
    for (size_t i = 0; i < b; i++) {
        if (n + 2 > capacity) return 0;
        out[n++] = body[i];
        if (n >= 10 && out[n - 3] == 0xFF && out[n - 2] == 0xFF && out[n - 1] == 0xFD) out[n++] = 0xFD;
    }
    if (n + 2 > capacity) return 0;
    size_t length = n - 7 + 2;
    out[0] = 0xFF; out[1] = 0xFF; out[2] = 0xFD; out[3] = 0x00;
    out[4] = BROADCAST;
    out[5] = (uint8_t)(length & 0xFF);
    out[6] = (uint8_t)(length >> 8);
    uint16_t crc = crc16(out, n);
    out[n++] = (uint8_t)(crc & 0xFF);
    out[n++] = (uint8_t)(crc >> 8);
    return n;
}
