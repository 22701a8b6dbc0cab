"""Prints the next COUNT snapshots of fusiond in NAMESPACE as JSON lines, read
with fusion_client (the test compares them with `fusionctl echo`'s).

Usage: python echo.py NAMESPACE COUNT
"""

import json
import sys

import fusion_client as fc


def main() -> int:
    namespace, count = sys.argv[1], int(sys.argv[2])
    reader = fc.Client(namespace).state_reader(buffer=512)
    print("ready", flush=True)
    for _ in range(count):
        s = reader.wait_next(timeout=60.0)
        if s is None:
            print("timeout", file=sys.stderr)
            return 1
        line = {
            "snapshot_seq": s.seq,
            "t_ns": s.t_ns,
            "kind": fc.wire.KIND_NAMES.get(s.sample_kind, "none"),
            "seq": s.sample_seq,
            "x": s.x.tolist(),
            "P": s.P.flatten().tolist(),
            "model": s.model_name,
            "health": s.health_name,
            "health_reasons": s.health_reason_names,
            "received": [c.counts.received for c in s.sensor_counters()],
            "fused": [c.counts.fused for c in s.sensor_counters()],
            "pending": None if s.settled else {"steps": s.pending_steps, "since_t_ns": s.pending_since_t_ns},
            "background_steps": s.background_steps,
        }
        print(json.dumps(line), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
