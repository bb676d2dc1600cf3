#!/usr/bin/env python3
"""keypose's bridge to the vendor servo SDKs: ROBOTIS `dynamixel_sdk` and Feetech `scservo_sdk`.

keypose (src/bus/sdk.rs) runs one of these processes per servo bus and speaks JSON lines with
it: one request object per line on stdin, one reply object per line on stdout, flushed after
each reply. The first line printed is the ready line:

    {"ready": true, "dynamixel_sdk": "4.1.0", "scservo_sdk": "1.0.0", "pyserial": "3.5",
     "python": "3.11.7", "executable": "/path/to/python",
     "packages": {"dynamixel-sdk": "4.1.0", "feetech-servo-sdk": "1.0.0", "pyserial": "3.5"}}

or, when a package is missing, {"ready": false, "error": "...", "missing": "<module>"}.

Requests (a "seq" member, when present, is echoed in the reply so the caller can drop replies
to requests it stopped waiting for):

    {"op": "open", "port": PATH, "baud": N, "protocol": "dynamixel-2"|"feetech-sts"|"feetech-scs"}
    {"op": "ping", "id": ID}                          -> {"model_number": N, "firmware": N|null}
    {"op": "read", "id": ID, "addr": A, "len": 1|2|4} -> {"value": RAW}
    {"op": "write", "id": ID, "addr": A, "len": L, "value": RAW}
    {"op": "sync_read", "addr": A, "len": L, "ids": [ID, ...]}   -> {"values": [RAW, ...]}
    {"op": "sync_write", "addr": A, "len": L, "values": [[ID, RAW], ...]}
    {"op": "bulk_read", "reads": [[ID, A, L], ...]}             -> {"values": [RAW, ...]}
    {"op": "bulk_write", "writes": [[ID, A, L, RAW], ...]}      (Dynamixel only, both)
    {"op": "close"}

Values are raw unsigned register contents; signs (two's complement on Dynamixel,
sign-magnitude on Feetech) are keypose's business, so the SDKs' own sign helpers are not used.

Replies are {"ok": true, ...} or {"ok": false, "kind": K, "error": TEXT, ...} where K is
"request" (malformed or invalid request), "state" (no port open, or one already open),
"port" (the serial port could not be opened: "port", "errno"), "comm" (the SDK's
communication result: "comm" is its text, "comm_kind" one of timeout, corrupt, tx_fail, busy,
tx_error, rx_fail, not_available, "servo" the id concerned, "elapsed_ms"), "servo" (the status
packet's error byte was not zero: "servo_error" is the SDK's text, "servo_error_code" the
byte, "value" what the answer carried: the register value of a read, the model and
firmware of a ping), "unsupported" or "internal".

One process drives one bus at a time: `open` while a bus is open is refused. This matters for
Feetech: scservo_sdk keeps the byte order in a module global set by PacketHandler(end)
(0 = little-endian STS/SMS, 1 = big-endian SCS), so two Feetech buses of different series in
one process would corrupt each other's values. After `close`, opening the other series sets
the global again; every Feetech operation also checks the global before touching the wire.
"""

import json
import os
import sys
import time

from harness_io import (
    RequestError,
    distribution_version,
    emit,
    handle_line,
    ignore_sigint,
    integer_in,
    interpreter,
    is_integer,
    member,
    not_ready,
    serve,
    take_stdout,
)

PROTOCOLS = ("dynamixel-2", "feetech-sts", "feetech-scs")

# How long one of the SDK's port reads may wait for bytes, seconds. Both SDKs open the port
# non-blocking (pyserial timeout=0) and poll `readPort` in a loop until the packet is complete
# or their packet timeout passes: a spin that keeps a core busy for every answer. On a loaded
# machine that spin competes with the servos (or the emulator) it waits for, and the bridge
# lost 85 % of its cycles beside six busy loops. With a read timeout, each `readPort` sleeps in
# select() until the bytes it asks for (the rest of the packet) have come or this much time
# has passed; the SDK's own timeout logic is unchanged, and ends at most this much later.
READ_WAIT_S = 0.002


def timeout_scale():
    """KEYPOSE_SDK_TIMEOUT_SCALE: a factor (1 or more) on the vendor SDKs' packet timeouts.

    The SDKs allow an answer a few milliseconds beyond its wire time (Dynamixel: twice the USB
    latency timer plus 2 ms; Feetech, as fixed upstream: 50 ms). On a machine loaded enough to
    delay the kernel's own delivery of bytes through a pseudo-terminal (CI beside busy loops),
    that is too short for an answer the emulated servos gave on time; the test command sets a
    larger factor there. Unset, or anything but a number of at least 1, leaves the SDKs' own.
    """
    try:
        return max(1.0, float(os.environ.get("KEYPOSE_SDK_TIMEOUT_SCALE", "1")))
    except ValueError:
        return 1.0


def scale_packet_timeouts(port_handler, port_handler_class, scale):
    """Multiply every packet timeout the port handler sets by `scale` (after the SDK computed it)."""
    if scale == 1.0:
        return
    by_length = port_handler.setPacketTimeout
    by_millis = port_handler.setPacketTimeoutMillis

    def set_packet_timeout(self, packet_length):  # noqa: N802 (SDK naming)
        by_length(packet_length)
        self.packet_timeout *= scale

    def set_packet_timeout_millis(self, msec):  # noqa: N802 (SDK naming)
        by_millis(msec)
        self.packet_timeout *= scale

    port_handler.setPacketTimeout = set_packet_timeout.__get__(port_handler, port_handler_class)
    port_handler.setPacketTimeoutMillis = set_packet_timeout_millis.__get__(port_handler, port_handler_class)


class BridgeError(RequestError):
    pass


def field(req, name, kind=int, lo=None, hi=None):
    value = member(req, name)
    if kind is int and not is_integer(value):
        raise BridgeError("request", f"{name!r} must be an integer, not {json.dumps(value)}")
    if kind is str and not isinstance(value, str):
        raise BridgeError("request", f"{name!r} must be a string, not {json.dumps(value)}")
    if kind is list and not isinstance(value, list):
        raise BridgeError("request", f"{name!r} must be a list, not {json.dumps(value)}")
    if lo is not None and value < lo or hi is not None and value > hi:
        raise BridgeError("request", f"{name!r} = {value} is outside {lo}..{hi}")
    return value


def patch_feetech_packet_timeout(port_handler, port_handler_class):
    """Use the packet timeout of the fixed upstream SDK.

    feetech-servo-sdk 1.0.0 on PyPI predates the fix of gitee ftservo/SCServoSDK issue IBY2S6;
    LeRobot, the main user of this package, patches PortHandler.setPacketTimeout the same way
    (lerobot/motors/feetech/feetech.py, patch_setPacketTimeout).
    """

    def set_packet_timeout(self, packet_length):  # noqa: N802 (SDK naming)
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = (self.tx_time_per_byte * packet_length) + (self.tx_time_per_byte * 3.0) + 50

    port_handler.setPacketTimeout = set_packet_timeout.__get__(port_handler, port_handler_class)


class Bus:
    """One open serial bus driven through one vendor SDK."""

    def __init__(self, dxl, scs, port_name, baud, protocol):
        self.protocol = protocol
        self.port_name = port_name
        self.dynamixel = protocol == "dynamixel-2"
        if self.dynamixel:
            sdk = dxl
            self.sdk_name = "dynamixel_sdk"
            self.ph = sdk.PacketHandler(2.0)
            self.lobyte, self.hibyte = sdk.DXL_LOBYTE, sdk.DXL_HIBYTE
            self.loword, self.hiword = sdk.DXL_LOWORD, sdk.DXL_HIWORD
            self.max_id = 252  # 253 and 255 cannot be ids, 254 is broadcast (docs/protocols.md §1.2)
            self.max_addr = 0xFFFF
            self.end = None
        else:
            sdk = scs
            self.sdk_name = "scservo_sdk"
            # PacketHandler(end) sets scservo_sdk's module-global byte order (see the module doc).
            self.end = 0 if protocol == "feetech-sts" else 1
            self.ph = sdk.PacketHandler(self.end)
            self.lobyte, self.hibyte = sdk.SCS_LOBYTE, sdk.SCS_HIBYTE
            self.loword, self.hiword = sdk.SCS_LOWORD, sdk.SCS_HIWORD
            self.max_id = 253  # 254 is broadcast (docs/protocols.md §2.1)
            self.max_addr = 0xFF
        self.sdk = sdk
        self.comm_kinds = {
            sdk.COMM_RX_TIMEOUT: "timeout",
            sdk.COMM_RX_CORRUPT: "corrupt",
            sdk.COMM_TX_FAIL: "tx_fail",
            sdk.COMM_PORT_BUSY: "busy",
            sdk.COMM_TX_ERROR: "tx_error",
            sdk.COMM_RX_FAIL: "rx_fail",
            sdk.COMM_NOT_AVAILABLE: "not_available",
        }
        self.port = sdk.PortHandler(port_name)
        if not self.dynamixel:
            patch_feetech_packet_timeout(self.port, sdk.PortHandler)
        scale_packet_timeouts(self.port, sdk.PortHandler, timeout_scale())
        self._open(baud)

    def _open(self, baud):
        try:
            opened = self.port.openPort()
        except Exception as e:  # pyserial's SerialException is an OSError with errno set
            raise BridgeError(
                "port",
                f"cannot open serial port {self.port_name}: {e}",
                port=self.port_name,
                errno=getattr(e, "errno", None),
            )
        if not opened:
            raise BridgeError("port", f"{self.sdk_name} could not open serial port {self.port_name}", port=self.port_name, errno=None)
        try:
            baud_ok = self.port.setBaudRate(baud)
        except Exception as e:
            self.close()
            raise BridgeError("port", f"serial port {self.port_name}: cannot set {baud} baud: {e}", port=self.port_name, errno=getattr(e, "errno", None))
        if not baud_ok:
            self.close()
            raise BridgeError("request", f"{self.sdk_name} does not support {baud} baud (its PortHandler.getCFlagBaud list)", port=self.port_name)
        # setBaudRate reopens the port with timeout=0, so this comes after it.
        self.port.ser.timeout = READ_WAIT_S

    def close(self):
        try:
            if self.port.is_open:
                self.port.closePort()
        except Exception:
            pass  # closing is best effort: the process is often about to exit

    def _guard_byte_order(self):
        if self.end is not None and self.sdk.SCS_GETEND() != self.end:
            raise BridgeError(
                "internal",
                f"scservo_sdk byte order is {self.sdk.SCS_GETEND()}, this {self.protocol} bus needs {self.end}",
            )

    def _check(self, servo, started, result, error=0, value=None):
        elapsed_ms = round((time.monotonic() - started) * 1000.0, 1)
        if result != self.sdk.COMM_SUCCESS:
            text = self.ph.getTxRxResult(result)
            about = f"servo {servo}" if servo is not None else self.port_name
            raise BridgeError(
                "comm",
                f"{about}: {text}",
                comm=text,
                comm_kind=self.comm_kinds.get(result, "unknown"),
                comm_code=result,
                servo=servo,
                elapsed_ms=elapsed_ms,
            )
        if error:
            text = self.ph.getRxPacketError(error)
            raise BridgeError(
                "servo",
                f"servo {servo}: {text}",
                servo_error=text,
                servo_error_code=error,
                servo=servo,
                value=value,
            )

    def _id(self, req, name="id"):
        return field(req, name, int, 0, self.max_id)

    def _addr_len(self, req):
        addr = field(req, "addr", int, 0, self.max_addr)
        length = field(req, "len", int)
        if length not in (1, 2, 4):
            raise BridgeError("request", f"'len' must be 1, 2 or 4, not {length}")
        return addr, length

    def _split(self, value, length):
        # The SDK's own byte helpers, as its users (LeRobot's _split_into_byte_chunks) do: for
        # scservo_sdk they follow the byte order chosen at PacketHandler(end).
        if length == 1:
            return [value & 0xFF]
        if length == 2:
            return [self.lobyte(value), self.hibyte(value)]
        return [
            self.lobyte(self.loword(value)),
            self.hibyte(self.loword(value)),
            self.lobyte(self.hiword(value)),
            self.hibyte(self.hiword(value)),
        ]

    def ping(self, req):
        servo = self._id(req)
        self._guard_byte_order()
        started = time.monotonic()
        if self.dynamixel:
            # The SDK's ping() builds this very packet but drops the firmware byte that the
            # status packet carries (docs/protocols.md §1.7); txRxPacket is the SDK's own exchange.
            p2 = sys.modules[type(self.ph).__module__]
            tx = [0] * 10
            tx[p2.PKT_ID] = servo
            tx[p2.PKT_LENGTH_L] = 3
            tx[p2.PKT_LENGTH_H] = 0
            tx[p2.PKT_INSTRUCTION] = self.sdk.INST_PING
            rx, result, error = self.ph.txRxPacket(self.port, tx)
            found = None
            if result == self.sdk.COMM_SUCCESS:
                p0 = p2.PKT_PARAMETER0
                model = self.sdk.DXL_MAKEWORD(rx[p0 + 1], rx[p0 + 2])
                found = {"model_number": model, "firmware": rx[p0 + 3]}
        else:
            # scservo_sdk's ping() pings, then reads the model number at address 3.
            model, result, error = self.ph.ping(self.port, servo)
            found = {"model_number": model, "firmware": None}
        # A servo with an alarm still answers, and says what it is: the reply keeps that.
        self._check(servo, started, result, error, value=found)
        return found

    def read(self, req):
        servo = self._id(req)
        addr, length = self._addr_len(req)
        self._guard_byte_order()
        reader = {1: self.ph.read1ByteTxRx, 2: self.ph.read2ByteTxRx, 4: self.ph.read4ByteTxRx}[length]
        started = time.monotonic()
        value, result, error = reader(self.port, servo, addr)
        self._check(servo, started, result, error, value=value)
        return {"value": value}

    def write(self, req):
        servo = self._id(req)
        addr, length = self._addr_len(req)
        value = field(req, "value", int, 0, (1 << (8 * length)) - 1)
        self._guard_byte_order()
        writer = {1: self.ph.write1ByteTxRx, 2: self.ph.write2ByteTxRx, 4: self.ph.write4ByteTxRx}[length]
        started = time.monotonic()
        result, error = writer(self.port, servo, addr, value)
        self._check(servo, started, result, error)
        return {}

    def sync_read(self, req):
        if self.protocol == "feetech-scs":
            raise BridgeError(
                "unsupported",
                "feetech-scs servos do not answer Sync Read: read them one by one",
            )
        addr, length = self._addr_len(req)
        ids = field(req, "ids", list)
        if not ids:
            raise BridgeError("request", "'ids' is empty")
        self._guard_byte_order()
        group = self.sdk.GroupSyncRead(self.port, self.ph, addr, length)
        for servo in ids:
            integer_in("each of 'ids'", servo, 0, self.max_id)
            if not group.addParam(servo):
                raise BridgeError("request", f"servo {servo} appears twice in 'ids'")
        started = time.monotonic()
        result = group.txRxPacket()
        if result != self.sdk.COMM_SUCCESS:
            # The group reads the answers in list order and stops at the first failure, so the
            # first id without its data is the one that failed.
            culprit = next((s for s in ids if len(group.data_dict.get(s) or []) < length), None)
            self._check(culprit, started, result)
        values = []
        for servo in ids:
            if len(group.data_dict.get(servo) or []) < length:
                raise BridgeError("comm", f"servo {servo}: no data in the sync read answer", comm=None, comm_kind="corrupt", comm_code=None, servo=servo)
            values.append(group.getData(servo, addr, length))
        return {"values": values}

    def sync_write(self, req):
        addr, length = self._addr_len(req)
        pairs = field(req, "values", list)
        if not pairs:
            raise BridgeError("request", "'values' is empty")
        self._guard_byte_order()
        group = self.sdk.GroupSyncWrite(self.port, self.ph, addr, length)
        for pair in pairs:
            if not isinstance(pair, list) or len(pair) != 2:
                raise BridgeError("request", f"each of 'values' must be [id, value], not {json.dumps(pair)}")
            servo = integer_in("a sync_write id", pair[0], 0, self.max_id)
            value = integer_in(f"servo {servo}'s value", pair[1], 0, (1 << (8 * length)) - 1)
            if not group.addParam(servo, self._split(value, length)):
                raise BridgeError("request", f"servo {servo} appears twice in 'values'")
        started = time.monotonic()
        result = group.txPacket()
        self._check(None, started, result)
        return {}


    def _bulk_entries(self, req, name, width):
        entries = field(req, name, list)
        if not entries:
            raise BridgeError("request", f"'{name}' is empty")
        if not self.dynamixel:
            raise BridgeError("unsupported", f"{self.protocol} has no bulk instructions")
        parsed = []
        for entry in entries:
            if not isinstance(entry, list) or len(entry) != width:
                raise BridgeError("request", f"each of '{name}' must have {width} numbers, not {json.dumps(entry)}")
            servo = integer_in("a bulk id", entry[0], 0, self.max_id)
            addr = integer_in(f"servo {servo}'s address", entry[1], 0, self.max_addr)
            length = integer_in(f"servo {servo}'s length", entry[2], 1, 4)
            parsed.append((servo, addr, length, *entry[3:]))
        return parsed

    def bulk_read(self, req):
        # GroupBulkRead: one request, one status packet per servo (docs/protocols.md §1.7).
        reads = self._bulk_entries(req, "reads", 3)
        group = self.sdk.GroupBulkRead(self.port, self.ph)
        for servo, addr, length in reads:
            if not group.addParam(servo, addr, length):
                raise BridgeError("request", f"servo {servo} appears twice in 'reads'")
        started = time.monotonic()
        result = group.txRxPacket()
        self._check(None, started, result)
        values = []
        for servo, addr, length in reads:
            if not group.isAvailable(servo, addr, length):
                raise BridgeError("comm", f"servo {servo}: no data in the bulk read answer", comm=None, comm_kind="corrupt", comm_code=None, servo=servo)
            values.append(group.getData(servo, addr, length))
        return {"values": values}

    def bulk_write(self, req):
        writes = self._bulk_entries(req, "writes", 4)
        group = self.sdk.GroupBulkWrite(self.port, self.ph)
        for servo, addr, length, value in writes:
            value = integer_in(f"servo {servo}'s value", value, 0, (1 << (8 * length)) - 1)
            if not group.addParam(servo, addr, length, self._split(value, length)):
                raise BridgeError("request", f"servo {servo} appears twice in 'writes'")
        started = time.monotonic()
        result = group.txPacket()
        self._check(None, started, result)
        return {}


class Bridge:
    def __init__(self, dxl, scs):
        self.dxl = dxl
        self.scs = scs
        self.bus = None

    def handle_line(self, line):
        return handle_line(line, self.dispatch)

    def dispatch(self, req):
        op = req.get("op")
        if op == "open":
            return self.open(req)
        if op == "close":
            if self.bus is not None:
                self.bus.close()
                self.bus = None
            return {}
        if op in ("ping", "read", "write", "sync_read", "sync_write", "bulk_read", "bulk_write"):
            if self.bus is None:
                raise BridgeError("state", f"{op}: no port is open (send 'open' first)")
            return getattr(self.bus, op)(req)
        raise BridgeError("request", f"unknown op {json.dumps(op)}")

    def open(self, req):
        port = field(req, "port", str)
        baud = field(req, "baud", int, 1)
        protocol = field(req, "protocol", str)
        if protocol not in PROTOCOLS:
            raise BridgeError("request", f"unknown protocol {protocol!r} (expected one of {', '.join(PROTOCOLS)})")
        if self.bus is not None:
            raise BridgeError(
                "state",
                f"{self.bus.port_name} is already open ({self.bus.protocol}); one bridge drives one bus, close it first",
            )
        self.bus = Bus(self.dxl, self.scs, port, baud, protocol)
        return {"sdk": self.bus.sdk_name}

    def shutdown(self):
        if self.bus is not None:
            self.bus.close()
            self.bus = None


def main():
    take_stdout()
    ignore_sigint()
    try:
        import dynamixel_sdk
        import scservo_sdk
    except ImportError as e:
        return not_ready(f"missing Python package: {e}", missing=getattr(e, "name", None))
    # "packages" is keyed by distribution name, as in requirements.txt, so that keypose can
    # compare it with its pins whatever the harness.
    packages = {name: distribution_version(name) for name in ("dynamixel-sdk", "feetech-servo-sdk", "pyserial")}
    emit(
        {
            "ready": True,
            "dynamixel_sdk": packages["dynamixel-sdk"],
            "scservo_sdk": packages["feetech-servo-sdk"],
            "pyserial": packages["pyserial"],
            **interpreter(),
            "packages": packages,
        }
    )
    bridge = Bridge(dynamixel_sdk, scservo_sdk)
    try:
        serve(bridge)
    finally:
        bridge.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
