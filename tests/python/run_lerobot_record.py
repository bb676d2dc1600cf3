"""``lerobot-record`` (LeRobot's own ``main``: plugin discovery, the teleoperator's registration,
its record loop, LeRobotDataset) run in this process with two stand-ins, for the recording test:

- the ``pattern`` camera of ``lerobot_stand_ins`` (no camera hardware);
- the Feetech SDK's packet timeout widened from 34 ms a read (its USB latency timer of 16 ms,
  twice, plus 2 ms) to 402 ms (the timer set to 200 ms): the emulated servos answer from another process on a shared, busy machine, and
  LeRobot reads each observation with a single try, so a 34 ms preemption would end the
  recording. Nothing else about the bus changes.
- the follower's ``disconnect`` tried again when its torque-off write went unanswered
  (``lerobot_arms.disconnect``'s reason: on a machine busy enough the emulated servos are not
  scheduled in time, and LeRobot raises with the robot still connected).

Arguments are lerobot-record's.
"""

import sys

import scservo_sdk.port_handler

scservo_sdk.port_handler.LATENCY_TIMER = 200

import lerobot_stand_ins  # noqa: E402,F401  (registers the pattern camera)
from lerobot.robots.so_follower.so_follower import SOFollower  # noqa: E402
from lerobot.scripts.lerobot_record import main  # noqa: E402

_disconnect = SOFollower.disconnect


def _disconnect_patiently(self: SOFollower, tries: int = 3) -> None:
    for attempt in range(tries):
        try:
            _disconnect(self)
            return
        except ConnectionError:
            if attempt == tries - 1:
                raise


SOFollower.disconnect = _disconnect_patiently

if __name__ == "__main__":
    sys.argv[0] = "lerobot-record"
    sys.exit(main())
