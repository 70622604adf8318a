#!/bin/sh
# can-utils against each other on vcan0, none of polyport's code: the reference peers the
# other vm tests rely on work in this guest. candump binds some time after it starts, so
# cansend repeats the frame every 20 ms until candump has one (candump -n 1) or has given
# up after 5 s without any (-T 5000).
out=$(mktemp)
trap 'rm -f "$out"' EXIT
candump -L -n 1 -T 5000 vcan0,5A5:7FF > "$out" &
candump_pid=$!
while kill -0 "$candump_pid" 2>/dev/null; do
  cansend vcan0 5A5#A55A || exit 1
  sleep 0.02
done
wait "$candump_pid" || { echo "candump failed"; exit 1; }
grep -q ' vcan0 5A5#A55A$' "$out" || { echo "candump printed: $(cat "$out")"; exit 1; }
