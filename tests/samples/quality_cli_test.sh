#!/bin/sh
# skelform-quality end to end: its command line refuses bad use with one line and the
# documented exit codes; on the procedural character (always available) the JSON report holds
# what --check decides, and --check passes there (LBS adds no pair on it and skelform none).
#   quality_cli_test.sh SKELFORM_QUALITY SKELFORM_CHARACTER WORK_DIR
set -u
QUALITY=$1 CHARACTER=$2 WORK=$3
rm -rf "$WORK" && mkdir -p "$WORK"
. "$(dirname "$0")/cli_test_lib.sh"

expect_failure "$QUALITY" "$WORK/none" 1
expect_failure "$QUALITY" "$WORK/none" 1 "$WORK/x.glb" --frames 1
expect_failure "$QUALITY" "$WORK/none" 1 "$WORK/x.glb" --bogus
expect_failure "$QUALITY" "$WORK/none" 1 "$WORK/x.glb" --waive everything
expect_failure "$QUALITY" "$WORK/none" 3 "$WORK/missing.glb"

"$CHARACTER" -o "$WORK/character.glb" >/dev/null || fail "skelform-character"
"$QUALITY" "$WORK/character.glb" --frames 3 --json -q >"$WORK/report.json" || fail "--json exited $?"
python3 - "$WORK/report.json" <<'PY' || fail "the JSON report"
import json, sys
report = json.load(open(sys.argv[1]))
f = report["files"][0]
assert "refused" not in f, f
assert f["closed"] is True, "the character is closed"
assert [a["name"] for a in f["animations"]] == ["walk", "bend"], f["animations"]
for a in f["animations"]:
    assert a["frames"] == 3 and len(a["pairs_added_per_frame"]) == 3
    for skelform, lbs in a["pairs_added_per_frame"]:
        assert skelform <= lbs, (a["name"], skelform, lbs)
    for method in ("skelform", "lbs"):
        assert 0 <= a["pairs_added_at_junctions"][method] <= a["pairs_added"][method], a
    v = a["volume_change"]["mean"]
    assert v["skelform"] <= v["lbs"], v
assert f["rest_error"] <= 1e-5 and f["bind_error"] <= 1e-5, (f["rest_error"], f["bind_error"])
assert f["total"]["rigid_deviation"] <= 1e-6
assert report["broken"] == [], report["broken"]
PY
"$QUALITY" "$WORK/character.glb" --frames 3 --check -q >"$WORK/check.txt" || fail "--check exited $? on the character"
grep -q "acceptance: every line holds" "$WORK/check.txt" || fail "--check summary: $(tail -3 "$WORK/check.txt")"

# --fresh: every measured frame from rest. LBS measures the same as when played; skelform's
# later frames are fresh starts, not warm ones, so its volumes differ somewhere (the character
# adds no pairs either way); and --check holds there too.
"$QUALITY" "$WORK/character.glb" --frames 3 --fresh --json -q >"$WORK/fresh.json" || fail "--fresh exited $?"
python3 - "$WORK/report.json" "$WORK/fresh.json" <<'PY' || fail "the --fresh report"
import json, sys
played, fresh = (json.load(open(p))["files"][0] for p in sys.argv[1:3])
assert [a["name"] for a in played["animations"]] == [a["name"] for a in fresh["animations"]]
differs = False
for a, b in zip(played["animations"], fresh["animations"]):
    assert len(b["pairs_added_per_frame"]) == 3
    assert a["volume_change"]["mean"]["lbs"] == b["volume_change"]["mean"]["lbs"], (a["name"], a, b)
    differs |= a["volume_change"]["mean"]["skelform"] != b["volume_change"]["mean"]["skelform"]
assert differs, "--fresh measured what playing measures"
PY
"$QUALITY" "$WORK/character.glb" --frames 3 --fresh --check -q >"$WORK/fresh.txt" || fail "--fresh --check exited $?"
grep -q "acceptance: every line holds" "$WORK/fresh.txt" || fail "--fresh --check summary: $(tail -3 "$WORK/fresh.txt")"

# --cuts: each animation's first frame without SF_EVAL_FROM_REST (the first one goes on from
# the tool's evaluation of the bind pose, the later ones from the previous animation; a pose
# jump where the runtime detects one). LBS measures the same as when played, skelform differs
# somewhere; --check holds; and --cuts excludes --fresh.
"$QUALITY" "$WORK/character.glb" --frames 3 --cuts --json -q >"$WORK/cuts.json" || fail "--cuts exited $?"
python3 - "$WORK/report.json" "$WORK/cuts.json" <<'PY' || fail "the --cuts report"
import json, sys
played, cuts = (json.load(open(p))["files"][0] for p in sys.argv[1:3])
differs = False
for a, b in zip(played["animations"], cuts["animations"]):
    assert a["volume_change"]["mean"]["lbs"] == b["volume_change"]["mean"]["lbs"], (a["name"], a, b)
    differs |= a["volume_change"]["mean"]["skelform"] != b["volume_change"]["mean"]["skelform"]
assert differs, "--cuts measured what playing measures"
PY
"$QUALITY" "$WORK/character.glb" --frames 3 --cuts --check -q >"$WORK/cuts.txt" || fail "--cuts --check exited $?"
grep -q "acceptance: every line holds" "$WORK/cuts.txt" || fail "--cuts --check summary: $(tail -3 "$WORK/cuts.txt")"
status=0
"$QUALITY" "$WORK/character.glb" --fresh --cuts -q >/dev/null 2>"$WORK/both.txt" || status=$?
[ "$status" -eq 1 ] || fail "--fresh --cuts exited $status, expected 1 (usage)"
grep -q "exclude each other" "$WORK/both.txt" || fail "--fresh --cuts message: $(cat "$WORK/both.txt")"

[ "$failures" -eq 0 ] || exit 1
echo "quality_cli: all checks passed"
