#!/bin/sh
# Checks the installed Debian package as an operator would use it, inside the image
# (../shared/tools/container-check -- sh /usr/share/sceneloc/check-package.sh): the
# unit's ExecStart is run as it stands (systemd does not run in a container), as the
# package's user, on the maps folder the unit names, with a map trained into that folder;
# the client lists the map, localises a frame, and the server reloads on SIGHUP and stops
# cleanly on SIGTERM. Exits non-zero with a message on the first thing that is wrong.
set -eu
fail() { echo "check-package: $*" >&2; exit 1; }
unit=/lib/systemd/system/sceneloc-server.service
[ -f "$unit" ] || fail "no unit $unit"
start=$(sed -n 's/^ExecStart=//p' "$unit")
maps=$(echo "$start" | sed -n 's/.*--maps \([^ ]*\).*/\1/p')
[ -n "$maps" ] || fail "the unit names no --maps folder: $start"
[ -d "$maps" ] || fail "the unit's maps folder $maps does not exist"
[ "$(stat -c %U "$maps")" = sceneloc ] || fail "$maps is not owned by the sceneloc user"
grep -q '^User=sceneloc$' "$unit" || fail "the unit does not run as sceneloc"
grep -q '^ExecReload=/bin/kill -HUP \$MAINPID$' "$unit" || fail "no SIGHUP reload in the unit"
for tool in sceneloc-server sceneloc-broker sceneloc sceneloc-train sceneloc-gentour; do
  "$tool" --version >/dev/null || fail "$tool --version failed"
done
as=""
# setpriv execs (no parent process left between us and the server: signals reach it).
[ "$(id -u)" = 0 ] && as="setpriv --reuid=sceneloc --regid=sceneloc --init-groups"
[ "$(id -un)" = sceneloc ] || [ -n "$as" ] || fail "run as root or as sceneloc"

work=$(mktemp -d)
[ -n "$as" ] && chown sceneloc:sceneloc "$work"
pid=""
trap '[ -n "$pid" ] && kill "$pid" 2>/dev/null; rm -rf "$work" "$maps/check.scnl"' EXIT
$as sceneloc-gentour --out "$work/gen" --locations 12 --width 480 --height 270 >/dev/null
$as sceneloc-train --tour "$work/gen/tour" --out "$maps/check.scnl" \
  --config /etc/sceneloc/train.yaml >/dev/null 2>&1 || fail "training into $maps failed"
# The unit's command line, on a port of its own.
$as $start --endpoint tcp://127.0.0.1:5599 >"$work/server.log" 2>&1 &
pid=$!
i=0
until sceneloc maps --server tcp://127.0.0.1:5599 --timeout-ms 500 >"$work/maps.txt" 2>/dev/null; do
  i=$((i + 1))
  [ $i -lt 60 ] || { cat "$work/server.log" >&2; fail "no answer from the server"; }
  sleep 0.5
done
grep -q "^check	generation 1" "$work/maps.txt" || fail "map not served: $(cat "$work/maps.txt")"
grep -q "trained by $(sceneloc --version)" "$work/maps.txt" || fail "no trained-by version"
sceneloc localise --server tcp://127.0.0.1:5599 --map check "$work/gen/test/Image005.jpg" \
  >"$work/answer.txt" || fail "localise failed: $(cat "$work/answer.txt")"
grep -q "check@1" "$work/answer.txt" || fail "unexpected answer: $(cat "$work/answer.txt")"
kill -HUP "$pid"
i=0
until sceneloc maps --server tcp://127.0.0.1:5599 | grep -q "generation 2"; do
  i=$((i + 1))
  [ $i -lt 40 ] || { cat "$work/server.log" >&2; fail "SIGHUP did not reload the map"; }
  sleep 0.5
done
kill -TERM "$pid"
wait "$pid" || fail "the server did not exit 0 on SIGTERM"
pid=""
cat "$work/answer.txt"
echo "check-package: the package serves $maps as its unit says ($(sceneloc --version))"
