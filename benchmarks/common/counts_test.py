#!/usr/bin/python3
"""counts.py (ping-pong middles counted per round trip) on its inputs: strace -c tables with and
without an errors column, callgrind profiles (a real one of /bin/true: every instruction
lands in one library), the matrix result's cases and their commands, the per-round-trip
difference and the table. Label unit; no benchmark runs."""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import counts  # noqa: E402

STRACE = """% time     seconds  usecs/call     calls    errors syscall
------ ----------- ----------- --------- --------- ----------------
 45.00    0.099445       49722         2           poll
 31.61    0.069867          55      1250           pselect6
  3.48    0.007692           6      1230       376 futex
  1.31    0.002895           4       688         1 read
------ ----------- ----------- --------- --------- ----------------
100.00    0.220981          42      5170       377 total
"""


class Counts(unittest.TestCase):
    def test_strace_table_gives_calls_by_name_whether_or_not_they_failed(self):
        with tempfile.NamedTemporaryFile("w", suffix=".strace", delete=False) as f:
            f.write(STRACE)
        try:
            self.assertEqual(counts.syscalls(f.name), {"poll": 2, "pselect6": 1250, "futex": 1230, "read": 688})
        finally:
            os.unlink(f.name)

    def test_callgrind_profile_is_split_by_library_without_losing_an_instruction(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "true.callgrind")
            subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out, "/bin/true"],
                           capture_output=True, check=True)
            by_library = counts.instructions(out)
            annotated = subprocess.run(["callgrind_annotate", "--auto=no", out], capture_output=True, text=True).stdout
        total = int(re.search(r"([\d,]+) \(100.0%\)\s+PROGRAM TOTALS", annotated).group(1).replace(",", ""))
        self.assertEqual(sum(by_library.values()), total)
        self.assertGreater(by_library.get("ld.so", 0), 0)  # the loader runs before main
        self.assertGreater(by_library.get("libc", 0), 0)

    def test_objects_and_inlined_code_are_named_after_their_owner(self):
        self.assertEqual(counts.library_of("/work/build/bin/polyportd"), "polyport")
        self.assertEqual(counts.library_of("/work/build/lib/libpolyport_core.so"), "polyport")
        self.assertEqual(counts.library_of("/work/build/bin/pingpong_lcm"), "program")
        self.assertEqual(counts.library_of("/usr/lib/x86_64-linux-gnu/liblcm.so.1.3.4"), "liblcm")
        self.assertEqual(counts.library_of("/usr/lib/x86_64-linux-gnu/libc.so.6"), "libc")
        self.assertEqual(counts.library_of("/work/build/bin/relay_fastdds_lcm"), "program")
        self.assertEqual(counts.library_of("/usr/lib/x86_64-linux-gnu/libfastrtps.so.2.9"), "fastdds")
        self.assertEqual(counts.library_of("/usr/lib/x86_64-linux-gnu/libddsc.so.0"), "cyclonedds")
        self.assertEqual(counts.library_of("/usr/lib/x86_64-linux-gnu/libssl.so.3"), "other")
        self.assertEqual(counts.owner_of("/usr/include/c++/12/bits/atomic_base.h:polyport::Connection::deliver"),
                         "polyport")
        self.assertEqual(counts.owner_of("bench_lcm_ping16_t.c:__bench_lcm_ping16_t_encode_array"), "program")
        self.assertEqual(counts.owner_of("./elf/../sysdeps/generic/dl-new-hash.h:_dl_lookup_symbol_x"), "other")

    def test_per_round_trip_is_the_difference_of_the_two_runs(self):
        short = {"futex": 100, "sendmsg": 2000, "mmap": 180}
        long_ = {"futex": 4100, "sendmsg": 6000, "mmap": 180, "write": 4000}
        self.assertEqual(counts.per_round_trip(short, long_, 2000), {"futex": 2.0, "sendmsg": 2.0, "write": 2.0})

    def test_matrix_cases_are_the_one_core_cross_pairs_with_their_domains_and_relay(self):
        cases = [
            {"placement": "one-core", "from": "fastdds", "to": "lcm", "size_bytes": 16, "relay_program": "relay_fastdds_lcm",
             "domains": {"via_ping": 155, "via_pong": 7806, "relay_ping": 157, "relay_pong": 7808}},
            {"placement": "unpinned", "from": "lcm", "to": "fastdds", "size_bytes": 16, "relay_program": "relay_fastdds_lcm",
             "domains": {"via_ping": 7801, "via_pong": 156, "relay_ping": 7803, "relay_pong": 158}},
            {"placement": "one-core", "from": "lcm", "to": "lcm", "size_bytes": 16, "relay_program": "pingpong_lcm",
             "domains": {}},
            {"placement": "one-core", "from": "lcm", "to": "inprocess", "size_bytes": 16, "domains": {}}]
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump({"cases": cases}, f)
        try:
            args = argparse.Namespace(result=f.name, bin="/b", profiles="/p")
            found = list(counts.matrix_cases(args))
        finally:
            os.unlink(f.name)
        self.assertEqual([c["label"] for c in found], ["fastdds -> lcm"])
        case = found[0]
        self.assertEqual(case["cwd"], "/p/one-core-fastdds-lcm-16")
        ping, pong, middle = case["middles"]["polyportd"]
        self.assertEqual(ping, ["/b/pingpong_fastdds", "ping", "155", "16"])
        self.assertEqual(pong, ["/b/pingpong_lcm", "pong", "7806", "16"])
        self.assertEqual(middle, ["/b/polyportd", "run", "/p/one-core-fastdds-lcm-16/app.xml"])
        ping, pong, middle = case["middles"]["relay"]
        self.assertEqual(ping, ["/b/pingpong_fastdds", "ping", "157", "16"])
        self.assertEqual(middle, ["/b/relay_fastdds_lcm", "fastdds", "157", "7808", "16"])

    def test_lcm_cases_are_the_one_core_cases_with_their_ports(self):
        cases = [{"placement": "unpinned", "size_bytes": 16, "ports": {}},
                 {"placement": "one-core", "size_bytes": 1024,
                  "ports": {"direct": 7700, "via_ping": 7701, "via_pong": 7702, "relay_ping": 7703, "relay_pong": 7704}}]
        with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
            json.dump({"cases": cases}, f)
        try:
            found = list(counts.lcm_cases(argparse.Namespace(result=f.name, bin="/b", profiles="/p")))
        finally:
            os.unlink(f.name)
        self.assertEqual([c["size_bytes"] for c in found], [1024])
        ping, pong, middle = found[0]["middles"]["polyportd"]
        self.assertEqual((ping, pong), (["/b/pingpong_lcm", "ping", "7701", "1024"], ["/b/pingpong_lcm", "pong", "7702", "1024"]))
        self.assertEqual(middle, ["/b/polyportd", "run", "/p/one-core-1024/app.xml"])
        self.assertEqual(found[0]["middles"]["relay"][2], ["/b/pingpong_lcm", "relay", "7703", "7704", "1024"])

    def test_table_has_a_row_per_case(self):
        result = {"benchmark": "lcm_counts", "date": "d", "revision": "r", "rounds": [1000, 3000], "cases": [
            {"case": "lcm", "middle": "polyportd", "size_bytes": 16,
             "syscalls_per_round_trip": {"recvmsg": 4.0, "futex": 0.2}, "syscalls_per_round_trip_total": 4.2,
             "instructions_per_round_trip": {"polyport": 900, "liblcm": 1900, "glib": 2300, "libc": 3400},
             "instructions_per_round_trip_total": 8500}]}
        rows = [line for line in counts.table(result).splitlines() if line.startswith("| lcm")]
        self.assertEqual(rows, ["| lcm | polyportd | 16 B | 4.2 (recvmsg 4) | 8500 | 900 | 4200 | 3400 | 0 |"])


if __name__ == "__main__":
    unittest.main()
