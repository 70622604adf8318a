#!/usr/bin/env bash
# cmake --install into a temporary prefix, moved afterwards (an installation does not depend
# on where it was made), then: an external project (external_plugin/) builds a component
# plugin against it with find_package(polyport) and installs the plugin next to the shipped
# ones; the installed polyportd checks the installed wheelchair profile and checks and runs a
# profile that uses the external plugin, whose output port is traced.
#   install_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
src=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
unset POLYPORT_LIBRARY_PATH

cmake --install "$build" --prefix "$work/staged" >"$work/install.log" || { cat "$work/install.log"; fail "cmake --install"; }
mv "$work/staged" "$work/prefix"
prefix=$work/prefix
polyportd=$prefix/bin/polyportd
for f in bin/polyportd bin/polyportctl lib/libpolyport_core.so lib/polyport/libpolyport_wheelchair.so \
         lib/cmake/polyport/polyportConfig.cmake lib/cmake/polyport/polyportConfigVersion.cmake \
         include/polyport/runtime/component_api.hpp share/polyport/profiles/wheelchair_inproc.xml \
         share/polyport/config/types/wheelchair.idl lib/systemd/system/polyportd.service; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
# The installed daemon uses the installed core library, not the build's.
core=$(ldd "$polyportd" | awk '/libpolyport_core.so/ {print $3}')
[ "$(realpath "$core")" = "$(realpath "$prefix/lib/libpolyport_core.so")" ] || fail "polyportd links '$core', not the installed core"
grep -q "^ExecStart=$work/staged/bin/polyportd run " "$prefix/lib/systemd/system/polyportd.service" ||
  fail "the unit does not name the installed polyportd: $(grep ExecStart "$prefix/lib/systemd/system/polyportd.service")"
"$polyportd" --version | grep -q '^polyportd ' || fail "polyportd --version"

# The shipped application, its plugin found in the installed lib/polyport.
"$polyportd" check "$prefix/share/polyport/profiles/wheelchair_inproc.xml" >"$work/check_wheelchair.txt" 2>&1 ||
  { cat "$work/check_wheelchair.txt"; fail "check of the installed wheelchair profile"; }

# The external project, as a user would build it.
cmake -S "$src/tests/package/external_plugin" -B "$work/external" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >"$work/external.log" 2>&1 || { cat "$work/external.log"; fail "configure of the external project"; }
cmake --build "$work/external" >>"$work/external.log" 2>&1 || { cat "$work/external.log"; fail "build of the external plugin"; }
cmake --install "$work/external" >>"$work/external.log" 2>&1 || { cat "$work/external.log"; fail "install of the external plugin"; }
[ -e "$prefix/lib/polyport/libexternal_counter.so" ] || fail "the external plugin is not in the installed plugin folder"
cp -r "$src/tests/package/external_plugin/profiles" "$work/profiles"

"$polyportd" check "$work/profiles/counter_app.xml" >"$work/check_counter.txt" 2>&1 ||
  { cat "$work/check_counter.txt"; fail "check of the external plugin's profile"; }
grep -q "Counter" "$work/check_counter.txt" || { cat "$work/check_counter.txt"; fail "check does not list Counter"; }

"$polyportd" run "$work/profiles/counter_app.xml" --duration 1 --admin-socket none -q \
  --stats-json "$work/stats.json" --trace Counter.count --trace-file "$work/trace.jsonl" >"$work/run.log" 2>&1 ||
  { cat "$work/run.log"; fail "run of the external plugin's profile"; }
python3 - "$work/stats.json" "$work/trace.jsonl" <<'PY' || fail "the external component did not run as expected"
import json, sys
stats = json.load(open(sys.argv[1]))
components = stats["components"]
counter = components["Counter"] if isinstance(components, dict) else next(c for c in components if c.get("name") == "Counter")
print("Counter:", {k: counter[k] for k in ("state", "executions", "errors") if k in counter})
assert counter.get("executions", 0) > 0, "no executions"
values = [json.loads(line)["value"]["value"] for line in open(sys.argv[2]) if line.strip()]
print(f"trace: {len(values)} samples, first {values[:3]}")
assert values, "no sample traced"
# step = 3 from the component profile, written every cycle in order
assert all(b - a == 3 for a, b in zip(values, values[1:])) and values[0] % 3 == 0, values[:10]
PY
echo "install, find_package plugin, check and run: ok"
