#!/usr/bin/env python3
"""polyportd under systemd's notification protocol, with a datagram socket this test owns as
NOTIFY_SOCKET: READY=1 with a STATUS= line once it runs, WATCHDOG=1 again and again while
WATCHDOG_USEC/WATCHDOG_PID name it, STOPPING=1 on SIGTERM; and no pings when WATCHDOG_PID names
another process (sd_watchdog_enabled(3)).

    sd_notify_test.py POLYPORTD PROFILE
"""
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

DEADLINE_S = 30.0  # generous: CI machines are shared; every wait ends as soon as its message is in


def fail(message):
    print("FAIL:", message, file=sys.stderr)
    sys.exit(1)


def start(polyportd, profile, notify_path, watchdog_pid_expr):
    # WATCHDOG_PID must be the daemon's own pid: the shell exports its $$ and execs polyportd.
    script = f'export WATCHDOG_PID={watchdog_pid_expr}; exec "$0" run "$1" --admin-socket none -q'
    env = dict(os.environ, NOTIFY_SOCKET=notify_path, WATCHDOG_USEC="200000")
    return subprocess.Popen(["sh", "-c", script, polyportd, profile], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def receive_until(sock, messages, predicate, process):
    deadline = time.monotonic() + DEADLINE_S
    while not predicate(messages):
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        sock.settimeout(min(left, 0.5))
        try:
            messages.append(sock.recv(4096).decode())
        except socket.timeout:
            if process.poll() is not None and not predicate(messages):
                return False
    return True


def stop(process):
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=DEADLINE_S)
    except subprocess.TimeoutExpired:
        process.kill()
        fail("polyportd did not stop on SIGTERM")
    return process.returncode, err


def fields(messages):
    return [line for m in messages for line in m.split("\n") if line]


def main():
    polyportd, profile = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "notify.sock")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        sock.bind(path)

        # Watched: READY, then pings, then STOPPING.
        messages = []
        p = start(polyportd, profile, path, "$$")
        if not receive_until(sock, messages, lambda m: "READY=1" in fields(m), p):
            stop(p)
            fail(f"no READY=1 (received {messages})")
        if not any(f.startswith("STATUS=running ") for f in fields(messages)):
            fail(f"no STATUS= line with READY=1 (received {messages})")
        if not receive_until(sock, messages, lambda m: fields(m).count("WATCHDOG=1") >= 5, p):
            stop(p)
            fail(f"fewer than 5 WATCHDOG=1 pings (received {messages})")
        code, err = stop(p)
        if code != 0:
            fail(f"polyportd exited {code}: {err}")
        # STOPPING=1 is sent before the daemon exits: it is in the socket's queue by now.
        sock.setblocking(False)
        try:
            while True:
                messages.append(sock.recv(4096).decode())
        except BlockingIOError:
            pass
        if "STOPPING=1" not in fields(messages):
            fail(f"no STOPPING=1 after SIGTERM (received {messages})")
        print(f"watched: READY=1, {fields(messages).count('WATCHDOG=1')} WATCHDOG=1, STOPPING=1")

        # WATCHDOG_PID of another process: the watchdog is not this daemon's, so no pings;
        # READY still arrives, and the daemon runs past several would-be ping intervals.
        messages = []
        p = start(polyportd, profile, path, "1")
        if not receive_until(sock, messages, lambda m: "READY=1" in fields(m), p):
            stop(p)
            fail(f"no READY=1 with another process's WATCHDOG_PID (received {messages})")
        sock.setblocking(True)
        sock.settimeout(1.0)  # five would-be ping intervals of 100 ms
        try:
            while True:
                messages.append(sock.recv(4096).decode())
        except socket.timeout:
            pass
        code, err = stop(p)
        if code != 0:
            fail(f"polyportd exited {code}: {err}")
        if "WATCHDOG=1" in fields(messages):
            fail(f"WATCHDOG=1 sent although WATCHDOG_PID names another process (received {messages})")
        print("unwatched: READY=1, no WATCHDOG=1")


if __name__ == "__main__":
    main()
