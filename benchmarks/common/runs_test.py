#!/usr/bin/python3
"""runs.py (verdicts over several runs of a ping-pong benchmark) on made-up results: the
interval and confidence of the sign test, the verdicts and when too few runs give none, the
figures taken from each run, and files it refuses. Label unit; no benchmark runs."""
import json
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import runs  # noqa: E402


def case(placement, size, via, relay, paired=None, cpu=None, all_cpu=None, in_to_out=None, **key):
    """A case as the runners write it; figures in ns, None where the run has none."""
    targets = {"via_one_way_p50_ns": via, "relay_one_way_p50_ns": relay}
    if paired is not None:
        targets["via_minus_relay_paired_chunks"] = {"via_minus_relay_p50_ns": paired}
    if cpu is not None:
        targets["polyportd_cpu_per_round_trip_ns"], targets["relay_cpu_per_round_trip_ns"] = cpu
    if in_to_out is not None:
        targets["polyport_in_to_out_p99_ns"] = in_to_out
    c = dict(key, placement=placement, size_bytes=size, targets=targets)
    if all_cpu is not None:
        c["via_polyport"] = {"cpu_per_round_trip_ns": {"all": all_cpu[0]}, "rtt_ns": {"mean": 2.0 * via}}
        c["via_native_relay"] = {"cpu_per_round_trip_ns": {"all": all_cpu[1]}, "rtt_ns": {"mean": 2.0 * relay}}
    return c


class SignInterval(unittest.TestCase):
    def test_sixteen_values_take_the_fourth_from_each_end(self):
        s = runs.sign_interval(list(range(16, 0, -1)), 2000)
        self.assertEqual(s["interval_ns"], [4, 13])
        self.assertAlmostEqual(s["confidence"], 1 - 2 * 697 / 65536)  # 2 P(Bin(16, 1/2) <= 3)
        self.assertEqual(s["median_ns"], 8.5)

    def test_six_runs_decide_at_97_percent(self):
        holds = runs.sign_interval([1500, 1900, -300, 800, 2000, 1200], 2000)
        self.assertEqual((holds["verdict"], holds["interval_ns"]), ("holds", [-300, 2000]))
        self.assertAlmostEqual(holds["confidence"], 1 - 2 / 64)
        self.assertEqual(runs.sign_interval([2100, 2500, 3000, 2001, 4000, 2200], 2000)["verdict"], "misses")
        self.assertEqual(runs.sign_interval([1500, 1900, 2100, 800, 2000, 1200], 2000)["verdict"], "undecided")

    def test_five_runs_give_no_verdict_and_say_why(self):
        s = runs.sign_interval([100, 200, 300, 400, 500], 2000)
        self.assertEqual(s["verdict"], "undecided")
        self.assertAlmostEqual(s["confidence"], 1 - 2 / 32)
        self.assertEqual(s["why"], "5 runs: would say holds, at 93.8 %")

    def test_a_miss_below_95_percent_is_no_verdict_either(self):
        s = runs.sign_interval([2100, 2200, 2300], 2000)
        self.assertEqual((s["verdict"], s["interval_ns"]), ("undecided", [2100, 2300]))
        self.assertEqual(s["why"], "3 runs: would say misses, at 75.0 %")

    def test_no_values_no_interval(self):
        self.assertIsNone(runs.sign_interval([], 0))


class Summaries(unittest.TestCase):
    def write(self, directory, name, cases, benchmark="lcm_pingpong"):
        path = os.path.join(directory, name)
        with open(path, "w") as f:
            json.dump({"benchmark": benchmark, "git_revision": "abc", "started_utc": name, "cases": cases}, f)
        return path

    def test_each_case_gets_one_value_per_run_and_its_verdicts(self):
        with tempfile.TemporaryDirectory() as d:
            files = []
            for i in range(6):
                files.append(self.write(d, "run%d.json" % i, [
                    # The paired median is the run's value, not the series' medians' difference.
                    case("unpinned", 16, 60000, 50000, paired=1000 + i, cpu=(40000, 41000 + i),
                         all_cpu=(120000 + i, 118000), in_to_out=400 + i),
                    # No paired chunks: the series' medians' difference.
                    case("one-core", 16, 52500 + i, 50000, in_to_out=900 + 200 * (i == 5)),
                ]))
            summary = runs.summarize(runs.load(files))
        unpinned, one_core = summary["cases"]
        self.assertEqual(unpinned["label"], "unpinned 16 B")
        self.assertEqual([r["via_minus_relay_ns"] for r in unpinned["runs"]], [1000, 1001, 1002, 1003, 1004, 1005])
        self.assertTrue(all(r["from_chunks"] for r in unpinned["runs"]))
        self.assertEqual(unpinned["via_minus_relay"]["verdict"], "holds")
        self.assertEqual(unpinned["cpu_polyportd_minus_relay"]["verdict"], "holds")  # -1000 .. -1005
        self.assertEqual(unpinned["all_cpu_via_minus_relay"]["verdict"], "misses")  # +2000 .. +2005
        self.assertEqual(unpinned["runs"][0]["round_trip_mean_ns"], 20000.0)
        self.assertEqual(unpinned["round_trip_mean_via_minus_relay"]["verdict"], "misses")
        self.assertIsNone(one_core["round_trip_mean_via_minus_relay"])  # no round trips in that case
        self.assertEqual(unpinned["in_to_out_p99_worst_ns"], 405)
        self.assertTrue(unpinned["in_to_out_p99_within_1us_every_run"])
        self.assertEqual([r["via_minus_relay_ns"] for r in one_core["runs"]], [2500, 2501, 2502, 2503, 2504, 2505])
        self.assertFalse(one_core["runs"][0]["from_chunks"])
        self.assertEqual(one_core["via_minus_relay"]["verdict"], "misses")
        self.assertIsNone(one_core["cpu_polyportd_minus_relay"])
        self.assertFalse(one_core["in_to_out_p99_within_1us_every_run"])  # 1.1 us in the last run
        self.assertEqual(one_core["in_to_out_p99_worst_ns"], 1100)

    def test_older_results_are_paired_from_their_chunk_figures(self):
        c = case("unpinned", 8, 60000, 50000)
        c["via_polyport"] = {"one_way_p50_per_chunk_ns": [10, 20, 30, 40]}
        c["via_native_relay"] = {"one_way_p50_per_chunk_ns": [9, 10, 35, 20]}
        f = runs.figures(c)  # d = 1, 10, -5, 20: median of -5, 1, 10, 20
        self.assertEqual((f["via_minus_relay_ns"], f["from_chunks"], f["series_medians_ns"]), (5, True, 10000))
        c["via_native_relay"]["one_way_p50_per_chunk_ns"].pop()  # counts differ: the series' medians
        self.assertEqual(runs.figures(c)["via_minus_relay_ns"], 10000)

    def test_dds_results_give_their_relay_and_cpu_figures(self):
        # The DDS runner: the relay's figures in "against_native_relay", the CPU in the series.
        c = {"placement": "one-core", "vendor": "fastdds", "size_bytes": 16,
             "targets": {"via_one_way_p50_ns": 70000, "polyport_in_to_out_p99_ns": 300},
             "against_native_relay": {"relay_one_way_p50_ns": 69000, "via_polyport_minus_relay_p50_ns": 1000,
                                      "via_minus_relay_paired_chunks": {"via_minus_relay_p50_ns": 700}},
             "via_polyport": {"cpu_per_round_trip_ns": {"polyportd": 60000, "all": 140000}},
             "via_native_relay": {"cpu_per_round_trip_ns": {"relay": 61500, "all": 139000}}}
        f = runs.figures(c)
        self.assertEqual((f["via_minus_relay_ns"], f["series_medians_ns"], f["cpu_ns"], f["all_cpu_ns"],
                          f["in_to_out_p99_ns"]), (700, 1000, -1500, 1000, 300))
        self.assertEqual(runs.label(runs.case_key(c)), "one-core fastdds 16 B")

    def test_matrix_cases_are_told_apart_by_their_pair(self):
        with tempfile.TemporaryDirectory() as d:
            path = self.write(d, "m.json", [case("unpinned", 16, 3, 1, **{"from": "lcm", "to": "fastdds"}),
                                            case("unpinned", 16, 5, 1, **{"from": "fastdds", "to": "lcm"})],
                              benchmark="matrix")
            summary = runs.summarize(runs.load([path]))
        self.assertEqual([c["label"] for c in summary["cases"]], ["unpinned lcm -> fastdds 16 B",
                                                                  "unpinned fastdds -> lcm 16 B"])
        self.assertEqual([c["runs"][0]["via_minus_relay_ns"] for c in summary["cases"]], [2, 4])

    def test_it_refuses_files_of_two_benchmarks_or_without_cases(self):
        with tempfile.TemporaryDirectory() as d:
            lcm = self.write(d, "a.json", [case("unpinned", 16, 2, 1)])
            can = self.write(d, "b.json", [case("unpinned", 8, 2, 1)], benchmark="can_pingpong")
            with self.assertRaisesRegex(ValueError, "different benchmarks: can_pingpong, lcm_pingpong"):
                runs.load([lcm, can])
            other = os.path.join(d, "c.json")
            with open(other, "w") as f:
                json.dump({"benchmark": "x"}, f)
            with self.assertRaisesRegex(ValueError, "c.json: not a ping-pong benchmark's result"):
                runs.load([other])
            self.assertEqual(runs.main([os.path.join(d, "missing.json")]), 2)
            summary = os.path.join(d, "s.json")
            with open(summary, "w") as f:
                json.dump(runs.summarize(runs.load([lcm])), f)
            with self.assertRaisesRegex(ValueError, "s.json: a summary over runs"):
                runs.load([summary])

    def test_out_writes_the_table_and_the_figures(self):
        with tempfile.TemporaryDirectory() as d:
            path = self.write(d, "a.json", [case("unpinned", 16, 60000, 50000, paired=1500)])
            stdout = sys.stdout
            sys.stdout = open(os.devnull, "w")
            try:
                self.assertEqual(runs.main(["--out", os.path.join(d, "out"), path]), 0)
            finally:
                sys.stdout.close()
                sys.stdout = stdout
            with open(os.path.join(d, "out.json")) as f:
                self.assertEqual(json.load(f)["cases"][0]["runs"][0]["via_minus_relay_ns"], 1500)
            with open(os.path.join(d, "out.md")) as f:
                self.assertIn("| unpinned 16 B | +1.5 |", f.read())


if __name__ == "__main__":
    unittest.main()
