#!/usr/bin/env python3
"""The vendor SDK driven directly, the peer of `cargo bench --bench bus`: one bus cycle (a sync
write of the goals, a sync read of the present positions) in a plain Python loop over ROBOTIS
`dynamixel_sdk` or Feetech `scservo_sdk`, as LeRobot drives them (GroupSyncWrite and
GroupSyncRead, their parameters set each cycle, the values taken with getData), with no bridge
and no JSON between the loop and the SDK.

    python sdk_direct.py PORT BAUD PROTOCOL GOAL_ADDR GOAL_LEN PRESENT_ADDR PRESENT_LEN ID,ID,...

PROTOCOL is dynamixel-2 or feetech-sts. The port is opened as the SDKs open it (non-blocking
reads, polled until a packet is complete), with Feetech's packet timeout as LeRobot patches it
(the fix of gitee ftservo/SCServoSDK issue IBY2S6, which feetech-servo-sdk 1.0.0 predates).
The goals are the positions read once at start, so nothing moves.

Prints {"ready": true, ...} once the port is open and the first read succeeded. Then, for each
line "SECONDS" on stdin, runs cycles for that long (at least one) and prints one JSON line:
{"cycles": N, "seconds": S, "durations_us": [...successful cycles...], "errors": N,
"first_error": TEXT|null}. Ends at the end of stdin.
"""

import json
import sys
import time


def main():
    port_name, baud, protocol = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    goal_addr, goal_len, present_addr, present_len = (int(a) for a in sys.argv[4:8])
    ids = [int(i) for i in sys.argv[8].split(",")]
    if protocol == "dynamixel-2":
        import dynamixel_sdk as sdk

        ph = sdk.PacketHandler(2.0)
        lo, hi, loword, hiword = sdk.DXL_LOBYTE, sdk.DXL_HIBYTE, sdk.DXL_LOWORD, sdk.DXL_HIWORD
    elif protocol == "feetech-sts":
        import scservo_sdk as sdk

        ph = sdk.PacketHandler(0)
        lo, hi, loword, hiword = sdk.SCS_LOBYTE, sdk.SCS_HIBYTE, sdk.SCS_LOWORD, sdk.SCS_HIWORD
    else:
        raise SystemExit(f"unknown protocol {protocol!r}")
    port = sdk.PortHandler(port_name)
    if protocol == "feetech-sts":

        def set_packet_timeout(self, packet_length):  # noqa: N802 (SDK naming)
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = (self.tx_time_per_byte * packet_length) + (self.tx_time_per_byte * 3.0) + 50

        port.setPacketTimeout = set_packet_timeout.__get__(port, sdk.PortHandler)
    if not port.openPort() or not port.setBaudRate(baud):
        raise SystemExit(f"cannot open {port_name} at {baud}")
    writer = sdk.GroupSyncWrite(port, ph, goal_addr, goal_len)
    reader = sdk.GroupSyncRead(port, ph, present_addr, present_len)

    def split(value, length):
        if length == 2:
            return [lo(value), hi(value)]
        return [lo(loword(value)), hi(loword(value)), lo(hiword(value)), hi(hiword(value))]

    def read():
        reader.clearParam()
        for i in ids:
            reader.addParam(i)
        result = reader.txRxPacket()
        if result != sdk.COMM_SUCCESS:
            raise RuntimeError(ph.getTxRxResult(result))
        return [reader.getData(i, present_addr, present_len) for i in ids]

    def cycle(goals):
        writer.clearParam()
        for i, goal in zip(ids, goals):
            writer.addParam(i, split(goal, goal_len))
        result = writer.txPacket()
        if result != sdk.COMM_SUCCESS:
            raise RuntimeError(ph.getTxRxResult(result))
        return read()

    goals = None
    for _ in range(5):
        try:
            goals = read()
            break
        except RuntimeError:
            time.sleep(0.05)
    if goals is None:
        raise SystemExit(f"no answer on {port_name}")
    print(json.dumps({"ready": True, "sdk": sdk.__name__, "goals": goals}), flush=True)

    for line in sys.stdin:
        length = float(line)
        durations, errors, first_error = [], 0, None
        cycles = 0
        start = time.perf_counter()
        while True:
            before = time.perf_counter()
            try:
                cycle(goals)
                durations.append((time.perf_counter() - before) * 1e6)
            except RuntimeError as e:
                errors += 1
                first_error = first_error or str(e)
            cycles += 1
            elapsed = time.perf_counter() - start
            if elapsed >= length:
                break
        print(
            json.dumps(
                {
                    "cycles": cycles,
                    "seconds": elapsed,
                    "durations_us": durations,
                    "errors": errors,
                    "first_error": first_error,
                }
            ),
            flush=True,
        )
    port.closePort()


if __name__ == "__main__":
    main()
