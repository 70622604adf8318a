"""What the Python benchmark runners share (bench_stress.py, soak.py, bench_dds_throughput.py)."""
import json
import os
import socket


def free_port():
    """A TCP port on 127.0.0.1 nobody listens on now (for polyportd --metrics-port)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def write_results(out_dir, name, stamp, result, markdown):
    """Writes OUT_DIR/NAME-STAMP.json (RESULT) and .md (MARKDOWN); returns the path without suffix."""
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{name}-{stamp}")
    with open(path + ".json", "w") as f:
        json.dump(result, f, indent=1)
    with open(path + ".md", "w") as f:
        f.write(markdown)
    return path
