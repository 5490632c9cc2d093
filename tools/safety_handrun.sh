#!/usr/bin/env bash
# The data-safety review, by hand: every case of its list (and a few more) run as a
# user would against a built `skin`, printing a markdown table with a verdict per case.
#   cargo build -p skin-cli && SKIN=target/debug/skin FX=fixtures tools/safety_handrun.sh
# Works in a scratch folder under /tmp (printed at the end); needs bash, python3, mkfifo.
set -u
SKIN=$(realpath "${SKIN:?binary}")
FX=$(cd "${FX:?fixtures}" && pwd)
W=$(mktemp -d /tmp/handrun.XXXX)
cd "$W"
cp -r "$FX/forearm" "$FX/arm" "$FX/hex_patch" "$FX/session" "$FX/models" .
N=0
row() { # id, case, verdict, evidence
  printf '| %s | %s | %s | %s |\n' "$1" "$2" "$3" "$(echo "$4" | tr '\n|' ' /' | cut -c1-150)"
}
# check ID "case" EXPECT_RC_REGEX MSG_REGEX POSTCHECK -- cmd...
check() {
  local id=$1 desc=$2 rcx=$3 msgx=$4 post=$5; shift 6
  local out rc
  out=$(timeout 300 "$@" 2>&1 >/dev/null); rc=$?
  local first=$(echo "$out" | grep -m1 '^error' || echo "$out" | grep -v '^\s*$' | tail -1)
  local ok=pass
  [[ $rc =~ ^($rcx)$ ]] || ok="FAIL(rc)"
  [[ -z $msgx ]] || echo "$out" | grep -Eq -- "$msgx" || ok="FAIL(msg)"
  if [[ -n $post ]] && ! eval "$post" >/dev/null 2>&1; then ok="FAIL(post)"; fi
  row "$id" "$desc" "$ok" "exit $rc: $first"
}
echo "| # | case | verdict | what it did |"
echo "|---|---|---|---|"
# ---- Data loss
mkdir -p user; cp session/run.toml user/; cp session/session.candump.log user/; echo notes > user/notes.txt
sed -i 's#\.\./#'"$W"'/#g; s#cache = .*#cache = "cache"#; s#truth = "session.tsv"#truth = "'"$W"'/session/session.tsv"#' user/run.toml
before=$(cd user && find . -type f | sort | xargs md5sum)
check D1 "run -o DIR holding the user's files" "1" "not empty|--force|skin output" '[[ "$(cd user && find . -type f | sort | xargs md5sum)" == "$before" ]]' -- $SKIN run user/run.toml --log user/session.candump.log -o user -q
check D2 "run -o . in the user's folder" "1" "not empty|--force|skin output" '[[ "$(cd user && find . -type f | sort | xargs md5sum)" == "$before" ]]' -- bash -c "cd user && $SKIN run run.toml --log session.candump.log -o . -q"
( $SKIN run user/run.toml --log user/session.candump.log -o two -q >/dev/null 2>&1 & p=$!; sleep 0.3; $SKIN run user/run.toml --log user/session.candump.log -o two -q > /dev/null 2> second.err; echo $? > second.rc; wait $p; echo $? > first.rc )
row D3 "two run into one -o at once" "$( [[ $(cat first.rc) == 0 && $(cat second.rc) != 0 && -f two/events.jsonl ]] && echo pass || echo FAIL)" "first exit $(cat first.rc), second exit $(cat second.rc): $(tail -1 second.err)"
cp forearm/touches.candump.log log.log; h=$(md5sum < log.log)
check D4 "replay LOG -o LOG" "1|2" "input" '[[ "$(md5sum < log.log)" == "$h" ]]' -- $SKIN replay --busmap forearm/busmap.toml log.log -o log.log
cp forearm/layout.json L.json; h=$(md5sum < L.json)
check D5 "flatten L -o L" "1|2" "input" '[[ "$(md5sum < L.json)" == "$h" ]]' -- $SKIN flatten L.json -o L.json
check D6 "flatten --svg L" "1|2" "input" '[[ "$(md5sum < L.json)" == "$h" ]]' -- $SKIN flatten L.json -o m.json --svg L.json
check D7 "busmap -o LAYOUT" "1|2" "input" '[[ "$(md5sum < L.json)" == "$h" ]]' -- $SKIN busmap --layout L.json -o L.json
$SKIN flatten L.json -o map.json >/dev/null 2>&1; hm=$(md5sum < map.json)
check D8 "degrade -o MAP" "1|2" "input" '[[ "$(md5sum < map.json)" == "$hm" ]]' -- $SKIN degrade --map map.json --remove 0.2 -o map.json
cp hex_patch/probes.csv P.csv; hp=$(md5sum < P.csv)
check D9 "calibrate -o PROBES" "1|2" "input" '[[ "$(md5sum < P.csv)" == "$hp" ]]' -- $SKIN calibrate P.csv -o P.csv
check D10 "probe-sim -o LAYOUT" "1|2" "input" '[[ "$(md5sum < L.json)" == "$h" ]]' -- $SKIN probe-sim --layout L.json -o L.json
if [[ $(id -u) == 0 ]]; then
  check D11 "-o /dev/full (root): written through, device kept" "1" "space|No space" '[[ -c /dev/full ]]' -- $SKIN flatten L.json -o /dev/full
fi
check D11b "-o /dev/null: written through, device kept" "0" "" '[[ -c /dev/null ]]' -- $SKIN flatten L.json -o /dev/null
mkfifo fifo; (cat fifo > fifo.out &) ; sleep 0.1
check D12 "-o FIFO: written through" "0" "" '[[ -p fifo && -s fifo.out ]]' -- $SKIN flatten L.json -o fifo
sleep 0.2
touch target.json; ln -s target.json link.json
check D13 "-o SYMLINK: target written, link kept" "0" "" '[[ -L link.json && -s target.json ]]' -- $SKIN flatten L.json -o link.json
$SKIN synth --layout L.json --count 40 --size 32x32 -o ds >/dev/null 2>&1
check D14 "synth smaller --count into its dataset" "0" "" '[[ $(ls ds/images | wc -l) == 10 && $(($(wc -l < ds/labels.csv)-1)) == 10 ]]' -- $SKIN synth --layout L.json --count 10 --size 32x32 -o ds
mkdir -p a b; $SKIN image --map map.json forearm/touches.txt -o imgs --size 68x100 -q >/dev/null 2>&1; cp imgs/touches/frame_00010.png a/x.png; cp imgs/touches/frame_00050.png b/x.png
check D15 "segment two inputs named alike" "0|1" "" '[[ ! -d seg || $(find seg -name "*.png" | wc -l) -ge 2 ]]' -- $SKIN segment --model models/handseg.onnx a/x.png b/x.png -o seg
awk 'NR==1||NR!=3' forearm/touches.txt > rep.txt; awk 'NR==2' forearm/touches.txt >> rep.txt
check D16 "image with a repeated frame number" "0" "" '[[ $(ls imgs2/rep | wc -l) == $(($(wc -l < rep.txt)-1)) ]]' -- $SKIN image --map map.json rep.txt -o imgs2 --size 68x100 -q
# interrupted image over an earlier output
$SKIN image --map map.json forearm/touches.txt -o int --size 68x100 -q >/dev/null 2>&1; hi=$(cd int && find . -type f | sort | xargs md5sum | md5sum)
$SKIN image --map map.json forearm/touches.txt -o int --size 4096x4096 -q >/dev/null 2>int.err & p=$!; sleep 3; kill -INT $p; wait $p; rc=$?
row D17 "image interrupted (SIGINT) over an earlier output" "$( [[ $rc == 130 && "$(cd int && find . -type f | sort | xargs md5sum | md5sum)" == "$hi" && ! -e int/.skin-partial ]] && echo pass || echo FAIL)" "exit $rc; earlier output unchanged, no .skin-partial"
$SKIN stitch --layout arm/layout.json --poses arm/poses.json arm/touch.txt --threshold 10 --step-mm 0.1 -o st >/dev/null 2>&1 & p=$!; sleep 4; kill -INT $p; wait $p; rc=$?
row D17b "stitch interrupted on its first run" "$( [[ $rc == 130 && ! -e st ]] && echo pass || echo FAIL)" "exit $rc; $( [[ -e st ]] && echo "st left: $(ls -A st)" || echo 'no folder left')"
python3 - <<'PY'
lines=open("session/session.candump.log").read().splitlines()
t0=float(lines[0][1:18]); span=float(lines[-1][1:18])-t0+0.05
out=[]
for k in range(12):
    out+=["(%.6f)%s"%(float(l[1:18])+k*span, l[19:]) for l in lines]
open("long.log","w").write("\n".join(out)+"\n")
PY
$SKIN run user/run.toml --log long.log -o runint -q >/dev/null 2>&1 & p=$!; sleep 2; kill -TERM $p; wait $p; rc=$?
row D18 "run interrupted (SIGTERM)" "$( [[ ! -e runint/summary.txt && -z "$(find . -name '*.partial*' -o -name '.skin-partial')" ]] && echo pass || echo FAIL)" "exit $rc; $(ls -A runint 2>/dev/null | tr '\n' ' ')"
# ---- Aborts, panics, runaway resources
check A1 "busmap --buses 4294967295" "1|2" "256|buses" "" -- $SKIN busmap --layout L.json --buses 4294967295
check A2 "synth --count 4000000000" "1|2" "count" "" -- $SKIN synth --layout L.json --count 4000000000 -o big
check A3 "image --size 100000x100000" "1|2" "4096" "" -- $SKIN image --map map.json forearm/touches.txt -o i3 --size 100000x100000
check A4 "synth --size 50000x50000" "1|2" "4096" "" -- $SKIN synth --layout L.json --count 10 --size 50000x50000 -o s4
check A5 "eval --threads 100000" "1|2" "256" "" -- $SKIN eval --model models/handsnet.onnx --dataset ds --threads 100000
sed 's/"rate": 200.0/"rate": 1e9/' "$FX/../skin-control/scenes/fig8_4.json" > rate.json
check A6 "scene rate 1e9" "1" "rate" "" -- $SKIN reach --scene rate.json --trials 1
sed 's/"radius": 0.04}/"radius": 1e100}/' "$FX/../skin-control/scenes/fig8_4.json" > cap.json
check A7 "reach, capsule radius 1e100" "1" "radius" "" -- $SKIN reach --scene cap.json --trials 1
check A7b "phri, capsule radius 1e100" "1" "radius" "" -- $SKIN phri --scene cap.json
# ---- Silently wrong
python3 - <<'PY'
import json
d=json.load(open("L.json")); d["links"][0]["taxels"][5]["position"][0]=1e308; json.dump(d,open("far.json","w"))
PY
check S1 "flatten, a taxel at 1e308 m" "1" "taxel|100 m" "" -- $SKIN flatten far.json -o far_map.json
$SKIN replay --busmap forearm/busmap.toml session/session.candump.log > /dev/null 2>&1
python3 - <<'PY'
lines=open("session/session.candump.log").read().splitlines()
t0=float(lines[0][1:18]); t1=float(lines[-1][1:18]); span=t1-t0+0.05
out=lines+["(%.6f)%s"%(float(l[1:18])+span, l[19:]) for l in lines]
open("joined.log","w").write("\n".join(out)+"\n")
PY
out=$($SKIN run user/run.toml --log joined.log -o joined -q 2>&1); rc=$?
row S2 "run on two sessions joined (counter restart)" "$( echo "$out" | grep -q "sync counter restarted" && grep -q counter_reset joined/events.jsonl && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | grep -E 'frames \(|restarted' | head -2)"
sed 's/^hand = .*/hand = "explode"/' user/run.toml > bad.toml
check S3 'run.toml hand = "explode"' "1" "comply" "" -- $SKIN run bad.toml --log user/session.candump.log -o badout -q
sed 's/^release_frames = .*/&\nreclassify_growth = nan/' user/run.toml > bad.toml
check S3 "run.toml reclassify_growth = nan" "1" "reclassify_growth" "" -- $SKIN run bad.toml --log user/session.candump.log -o badout -q
check S3b "classify --threshold nan" "1|2" "threshold|finite" "" -- $SKIN classify --model models/handsnet.onnx --threshold nan imgs/touches/frame_00010.png
check S3c "segment --threshold nan" "1|2" "threshold|finite" "" -- $SKIN segment --model models/handseg.onnx --threshold nan imgs/touches/frame_00010.png
check S3d "stitch --threshold nan" "1|2" "finite|threshold" "" -- $SKIN stitch --layout arm/layout.json --poses arm/poses.json --threshold nan -o x
check S3e "stitch --max-edge-mm nan" "1|2" "finite|edge" "" -- $SKIN stitch --layout arm/layout.json --poses arm/poses.json --max-edge-mm nan -o x
for f in nan -0.5 2; do check S3f "eval --test-fraction $f" "1|2" "fraction|between|finite|0" "" -- $SKIN eval --model models/handsnet.onnx --dataset ds --test-fraction=$f; done
check S3g "eval --patterns 0" "1|2" "patterns|1" "" -- $SKIN eval --model models/handsnet.onnx --dataset ds --test-b --patterns 0
check S3h "reach --trials 0" "1|2" "trials|1" "" -- $SKIN reach --trials 0
out=$($SKIN busmap --layout arm/layout.json 2>&1); rc=$?
row S4 "busmap on a two-link layout covers both links" "$( [[ $rc == 0 ]] && [[ $(echo "$out" | grep -c 'address') -ge 2 ]] && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | grep -c '^\[\[bus.module\]\]') modules mapped; $(python3 -c "import json;d=json.load(open('arm/layout.json'));print(len({t['id']>>4 for l in d['links'] for t in l['taxels']}),'modules in the layout')")"
check S4b "busmap --buses 1000 for 65 modules" "1|2" "256" "" -- $SKIN busmap --layout L.json --buses 1000
check S4b "busmap --buses 100 for 65 modules" "1|2" "empty|at most" "" -- $SKIN busmap --layout L.json --buses 100
awk 'NR==1{$2=$1} {print}' forearm/touches.txt > dupid.txt
check S4c "recording header repeating a taxel id" "1" "repeats|field" "" -- $SKIN image --map map.json dupid.txt -o dupimg
python3 -c "
import struct,zlib
def png(path,ct,bd,ch):
    w=h=8; raw=b''.join(b'\x00'+bytes(w*ch*(bd//8)) for _ in range(h))
    def chunk(t,d): return struct.pack('>I',len(d))+t+d+struct.pack('>I',zlib.crc32(t+d))
    open(path,'wb').write(b'\x89PNG\r\n\x1a\n'+chunk(b'IHDR',struct.pack('>IIBBBBB',w,h,bd,ct,0,0,0))+chunk(b'IDAT',zlib.compress(raw))+chunk(b'IEND',b''))
png('rgb.png',2,8,3); png('rgba.png',6,8,4); png('g16.png',0,16,1)"
for p in rgb rgba g16; do check S5 "classify $p.png" "1" "grey|8-bit|8 bit" "" -- $SKIN classify --model models/handsnet.onnx $p.png; done
# ---- Unclear errors
python3 - <<'PY'
import json
d=json.load(open("L.json")); d["links"][0]["taxels"][5]["position"]="x"; json.dump(d,open("shape.json","w"),indent=1)
PY
check U1 "JSON of the wrong shape" "1" "taxel .*index 5" "" -- $SKIN flatten shape.json -o u1.json
python3 - <<'PY'
import json
d=json.load(open("L.json")); d["links"][0]["taxels"][5]["position"][0]=float("nan")
open("nan.json","w").write(json.dumps(d).replace("NaN","1e999"))
PY
check U2 "a NaN / 1e999 coordinate" "1" "line|taxel" "" -- $SKIN flatten nan.json -o u2.json
sed '0,/\[0.0, 0.0, 0.0\]/s//[0.0, 0.0, 1e300]/' arm/poses.json > hugepose.json
check U3 "a huge pose" "1" "hugepose.json.*postures\[0\]" "" -- $SKIN stitch --layout arm/layout.json --poses hugepose.json -o u3
sed '0,/taxels = \[16,/s//taxels = [32,/' forearm/busmap.toml > dupmap.toml
check U4 "bus map with a taxel twice" "1" "also in" "" -- $SKIN replay --busmap dupmap.toml forearm/touches.candump.log
out=$($SKIN replay --busmap dupmap.toml forearm/touches.candump.log 2>&1); echo "$out" | grep -q "line 0" && row U4b "bus map error says line 0" FAIL "$out" || row U4b "no \"line 0\" in bus map errors" pass "$(echo "$out" | tail -1)"
mkdir -p folder.onnx
check U5 "model path that is a folder" "1" "folder" "" -- $SKIN classify --model folder.onnx imgs/touches/frame_00010.png
python3 -c "h=open('forearm/touches.txt').readline(); open('huge.txt','w').write(h+'0 0.0 '+'9x'*5_000_000+' 1'*(len(h.split())-1)+'\n')"
out=$($SKIN image --map map.json huge.txt -o hugeimg 2>&1); rc=$?
row U6 "a 10 MB bad line" "$( [[ $rc == 1 && ${#out} -lt 400 ]] && echo pass || echo FAIL)" "exit $rc, message ${#out} bytes: $(echo "$out" | tail -1 | cut -c1-120)"
cp forearm/touches.candump.log errf.log; sed -i '5i (1700000000.000001) can0 20000080#0000000000000000' errf.log
out=$($SKIN replay --busmap forearm/busmap.toml errf.log 2>&1); rc=$?
row U7 "candump error frame" "$( [[ $rc == 0 ]] && echo "$out" | grep -qi "error frame" && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | grep -i 'error frame' | head -1)"
out=$($SKIN flatten L.json -o map.json/m.json 2>&1); rc=$?
row U8 "an output that cannot be written names the user's path" "$( [[ $rc == 1 ]] && ! echo "$out" | grep -q partial && echo "$out" | grep -q "map.json/m.json" && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1)"
out=$($SKIN image --map map.json forearm/touches.txt -o map.json/imgs 2>&1); rc=$?
row U8b "an output folder that cannot be made names the user's path" "$( [[ $rc == 1 ]] && ! echo "$out" | grep -q partial && echo "$out" | grep -q "map.json/imgs" && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1)"
out=$($SKIN image --map map.json forearm/touches.txt -o /dev/full/imgs 2>&1); rc=$?
echo "lab notes" > notes.txt
check U9 "flatten L -o notes.txt (a user's other file)" "1" "exists and is not" '[[ "$(cat notes.txt)" == "lab notes" ]]' -- $SKIN flatten L.json -o notes.txt
check U9b "flatten again over its own map" "0" "" '[[ -s map.json ]]' -- $SKIN flatten L.json -o map.json
# ---- Bounded and honest under load: outputs whole or absent, one layout per batch (issue 34)
R="$SKIN run user/run.toml --log user/session.candump.log -q"
# A finished output folder: its files, a manifest that reads, no marker, no staging.
complete() { [[ -s $1/summary.txt && -f $1/events.jsonl && ! -e $1/INCOMPLETE && ! -e $1/.skin-partial ]] && python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$1/.skin-output"; }
# A marker that reads: its first line names the command, then a file a line.
marked() { [[ -s $1/INCOMPLETE ]] && head -1 "$1/INCOMPLETE" | grep -q '^skin run was moving its files'; }
snap() { (cd "$1" && find . -type f ! -name .skin-lock | sort | xargs md5sum) | md5sum; }
partials() { find "${1:-.}" \( -name '*.partial*' -o -name .skin-partial \) 2>/dev/null | head -3 | tr '\n' ' '; }
$R -o warm >/dev/null 2>&1   # the maps cached once, so that the disk fills with the run's own files
if [[ $(id -u) == 0 ]] && mkdir -p tfs && mount -t tmpfs -o size=4k tmpfs tfs 2>/dev/null; then
  bad=0; n=0; seen=""; whole=0; refused=0
  for kb in $(seq 4 4 160); do
    mount -o remount,size=${kb}k tfs; rm -rf tfs/out; n=$((n+1))
    $R -o tfs/out >/dev/null 2>tfs.err; rc=$?
    [[ $rc == 0 ]] && whole=$((whole+1)) || refused=$((refused+1))
    if [[ $rc == 0 ]]; then complete tfs/out || { bad=$((bad+1)); seen+="${kb}k: exit 0, not complete; "; }
    elif [[ -e tfs/out ]]; then bad=$((bad+1)); seen+="${kb}k: exit $rc left $(ls -A tfs/out | tr '\n' ' '); "
    elif grep -q '\.skin-partial' tfs.err; then bad=$((bad+1)); seen+="${kb}k: names staging; "; fi
  done
  row L1 "disk full at every size while a new folder is made (tmpfs 4k..160k)" "$( [[ $bad == 0 ]] && echo pass || echo FAIL)" "$n sizes: $whole complete, $refused failed and left no folder; $bad bad ${seen}"
  # Out of inodes: the new files of the commit itself (marker, manifest) are what fails.
  umount tfs; bad=0; n=0; seen=""; whole=0; refused=0
  for inodes in $(seq 20 1 34); do
    mount -t tmpfs -o size=1m,nr_inodes=$inodes tmpfs tfs; n=$((n+1))
    $R -o tfs/out >/dev/null 2>tfs.err; rc=$?
    [[ $rc == 0 ]] && whole=$((whole+1)) || refused=$((refused+1))
    if [[ $rc == 0 ]]; then complete tfs/out || { bad=$((bad+1)); seen+="$inodes: exit 0, not complete; "; }
    elif [[ -e tfs/out ]]; then bad=$((bad+1)); seen+="$inodes inodes: exit $rc left $(ls -A tfs/out | tr '\n' ' '); "; fi
    umount tfs
  done
  bad=0; m=0; kept=0; whole2=0
  for inodes in $(seq 30 1 60); do
    mount -t tmpfs -o size=1m,nr_inodes=$inodes tmpfs tfs; m=$((m+1))
    $R -o tfs/out >/dev/null 2>&1 && h=$(snap tfs/out) || { umount tfs; continue; }
    $R -o tfs/out >/dev/null 2>tfs.err; rc=$?
    if [[ $rc == 0 ]]; then whole2=$((whole2+1)); complete tfs/out || { bad=$((bad+1)); seen+="$inodes again: not complete; "; }
    elif [[ "$(snap tfs/out)" != "$h" ]] && ! marked tfs/out; then bad=$((bad+1)); seen+="$inodes again: earlier output changed; "
    else kept=$((kept+1)); fi
    umount tfs
  done
  mount -t tmpfs -o size=4k tmpfs tfs
  row L1b "no inode left at every step of a run (tmpfs 20..60 inodes), new folder and over an earlier output" "$( [[ $bad == 0 ]] && echo pass || echo FAIL)" "new folder, $n sizes: $whole complete, $refused failed and left no folder; over an earlier output, $m sizes: $whole2 complete, $kept failed with the earlier output kept; $bad bad ${seen}"
  mount -o remount,size=400k tfs; rm -rf tfs/*; $R -o tfs/out >/dev/null 2>&1; h=$(snap tfs/out)
  bad=0; n=0; seen=""; whole=0; marks=0; kept=0
  for left in $(seq 0 4 200); do
    free=$(df -B1 --output=avail tfs | tail -1); n=$((n+1))
    head -c $(( free > left*1024 ? free - left*1024 : 0 )) /dev/zero > tfs/filler 2>/dev/null
    $R -o tfs/out >/dev/null 2>tfs.err; rc=$?; rm -f tfs/filler
    if [[ $rc == 0 ]]; then whole=$((whole+1)); complete tfs/out || { bad=$((bad+1)); seen+="${left}k: not complete; "; }
    elif marked tfs/out; then marks=$((marks+1)); $R -o tfs/out >/dev/null 2>&1 && complete tfs/out || { bad=$((bad+1)); seen+="${left}k: marked, next run failed; "; }
    elif [[ "$(snap tfs/out)" != "$h" ]]; then bad=$((bad+1)); seen+="${left}k: earlier output changed; "
    else kept=$((kept+1)); fi
    h=$(snap tfs/out)
  done
  row L2 "disk full at every size over an earlier output" "$( [[ $bad == 0 ]] && echo pass || echo FAIL)" "$n sizes: $whole complete, $kept failed with the earlier output kept, $marks marked INCOMPLETE and taken up by the next run; $bad bad ${seen}"
  rm -rf tfs/*; mount -o remount,size=8k tfs
  out=$($R -o tfs/out --mcap other.mcap 2>&1); rc=$?
  row L3 "-o on a full disk, --mcap on another" "$( [[ $rc != 0 && ! -e other.mcap && ! -e tfs/out && -z "$(partials .)" ]] && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1); mcap $( [[ -e other.mcap ]] && echo 'in place' || echo absent)"
  mount -o remount,size=400k tfs; rm -rf tfs/*
  out=$($R -o tfs/out --mcap onfs.mcap 2>&1); rc=$?
  row H2 "output folder on another file system than the MCAP" "$( [[ $rc == 0 ]] && complete tfs/out && [[ -s onfs.mcap ]] && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | grep wrote | tr '\n' ' ')"
  h=$(snap tfs/out); mount -o remount,ro tfs
  out=$($R -o tfs/out 2>&1); rc=$?
  mount -o remount,rw tfs
  row H1 "a read-only output folder holding an earlier output" "$( [[ $rc == 1 && "$(snap tfs/out)" == "$h" ]] && echo "$out" | grep -q 'tfs/out' && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1)"
  umount tfs
fi
python3 - <<'PY'
import struct
magic=b"\x89MCAP0\r\n"
body=b"".join(struct.pack("<I",len(s))+s for s in (b"ros2",b"rosbag2_storage_mcap"))
open("robot.mcap","wb").write(magic+b"\x01"+struct.pack("<Q",len(body))+body+magic)
PY
h=$(md5sum < robot.mcap)
check L4 "--mcap over a bag another tool recorded" "1" "not an MCAP file that skin wrote" '[[ "$(md5sum < robot.mcap)" == "$h" && ! -e l4 ]]' -- $R -o l4 --mcap robot.mcap
( $SKIN run user/run.toml --log long.log -q -o m1 --mcap one.mcap >/dev/null 2>&1 & p=$!; sleep 1.5; $SKIN run user/run.toml --log user/session.candump.log -q -o m2 --mcap one.mcap >/dev/null 2>m2.err; echo $? > m2.rc; wait $p; echo $? > m1.rc )
row L5 "two runs writing one --mcap at once" "$( [[ $(cat m1.rc) == 0 && $(cat m2.rc) == 1 && ! -e m2 ]] && grep -q 'another skin command is writing this file' m2.err && echo pass || echo FAIL)" "first exit $(cat m1.rc), second exit $(cat m2.rc): $(tail -1 m2.err)"
$SKIN run user/run.toml --log long.log -q -o k1 --mcap killed.mcap >/dev/null 2>&1 & p=$!
for _ in $(seq 600); do [[ $(stat -c %s .killed.mcap.partial 2>/dev/null || echo 0) -gt 5000000 ]] && break; sleep 0.05; done
kill -KILL $p; wait $p 2>/dev/null
left=$(ls -A | grep '^\.killed'); size=$(du -sh .killed.mcap.partial 2>/dev/null | cut -f1)
$R -o k2 --mcap killed.mcap >/dev/null 2>&1; rc=$?
row L6 "SIGKILL mid-recording, then a run on the same --mcap" "$( [[ -n $left && $rc == 0 && -s killed.mcap && -z "$(ls -A | grep '^\.killed')" ]] && echo pass || echo FAIL)" "killed run left ${left:-nothing} ($size); next run exit $rc, $(ls -A | grep -c '^\.killed') hidden file(s) after"
$R -o k1 >/dev/null 2>&1; rc=$?
row L6b "the killed run's output folder, run again" "$( [[ $rc == 0 ]] && complete k1 && echo pass || echo FAIL)" "exit $rc; its staging folder $( [[ -e k1/.skin-partial ]] && echo left || echo removed)"
bad=0; seen=""
for k in 1 2 3 4 5 6; do
  sig=$( (( k % 2 )) && echo INT || echo TERM )
  $SKIN run user/run.toml --log long.log -q --frames -o sig$k >/dev/null 2>&1 & p=$!
  for _ in $(seq 600); do [[ $(ls sig$k/.skin-partial/frames/forearm 2>/dev/null | wc -l) -gt $((k*15)) ]] && break; sleep 0.01; done
  kill -$sig $p; wait $p; rc=$?
  [[ $rc == 130 && ! -e sig$k ]] || { bad=$((bad+1)); seen+="run $k ($sig) exit $rc left $(partials sig$k); "; }
done
row L7 "SIGINT/SIGTERM while writing frame images, 6 runs" "$( [[ $bad == 0 ]] && echo pass || echo FAIL)" "${seen:-6 of 6: exit 130, no folder left}"
# An interrupt at many moments of a run over an earlier output, and into a new folder.
$R -o every >/dev/null 2>&1; h=$(snap every); bad=0; seen=""
for d in 0 0.05 0.1 0.2 0.3 0.5 0.7 1 1.3 1.6 2 2.5 3 4; do
  $R -o every >/dev/null 2>&1 & p=$!; sleep $d; kill -INT $p 2>/dev/null; wait $p; rc=$?
  if [[ $rc == 0 ]]; then complete every || { bad=$((bad+1)); seen+="$d s: exit 0, not complete; "; }; h=$(snap every)
  elif [[ "$(snap every)" != "$h" || -e every/.skin-partial || -e every/INCOMPLETE ]]; then bad=$((bad+1)); seen+="$d s: exit $rc, earlier output changed; "; fi
  $R -o fresh$d >/dev/null 2>&1 & p=$!; sleep $d; kill -INT $p 2>/dev/null; wait $p; rc=$?
  if [[ $rc == 0 ]]; then complete fresh$d || { bad=$((bad+1)); seen+="$d s new: not complete; "; }
  elif [[ -e fresh$d ]]; then bad=$((bad+1)); seen+="$d s new: exit $rc left $(ls -A fresh$d | tr '\n' ' '); "; fi
done
row H6 "SIGINT at 14 moments (before the first frame .. at commit), over an earlier output and into a new folder" "$( [[ $bad == 0 && -z "$(partials every; partials . | grep fresh)" ]] && echo pass || echo FAIL)" "${seen:-each: complete, or the earlier output / no folder}"
PY=${SKIN_PYTHON:-python3}
if $PY -c 'import zenoh' 2>/dev/null; then
  port=$((20000 + RANDOM % 20000))
  $PY - $port > peer.out 2>&1 <<'PY' & peer=$!
import sys, time, zenoh
c = zenoh.Config(); c.insert_json5('mode', '"peer"'); c.insert_json5('listen/endpoints', f'["tcp/127.0.0.1:{sys.argv[1]}"]')
s = zenoh.open(c)
sub = s.declare_subscriber('**', lambda sample: time.sleep(0.05))  # a slow peer: 50 ms a sample
print('ready', flush=True); time.sleep(60)
PY
  for _ in $(seq 100); do grep -q ready peer.out && break; sleep 0.1; done
  $R -o drain --zenoh tcp/127.0.0.1:$port >/dev/null 2>drain.err & p=$!
  for _ in $(seq 600); do [[ -e drain/summary.txt ]] && break; sleep 0.05; done
  alive=$(kill -0 $p 2>/dev/null && echo yes || echo no); kill -INT $p 2>/dev/null; wait $p; rc=$?; kill $peer 2>/dev/null
  row L8 "Ctrl-C during the network drain after the last frame" "$( [[ $alive == yes && $rc == 130 ]] && complete drain && echo pass || echo FAIL)" "still draining: $alive; exit $rc: $(tail -1 drain.err)"
fi
# ---- A batch: one layout, every input checked first
mkdir -p batch; cp forearm/layout.json batch/layout.json
printf 'layout = "layout.json"\ncache = "cache"\n[baseline]\nframes = 5\n' > batch/rec.toml
for k in $(seq -w 1 70); do cp forearm/touches.txt batch/r$k.txt; done
$SKIN run batch/rec.toml --recording batch/r01.txt -o batch1 -q >/dev/null 2>&1
$SKIN run batch/rec.toml --recording batch/r*.txt -o batchout -q >/dev/null 2>batch.err & p=$!
for _ in $(seq 3000); do [[ -e batchout/.skin-partial/r01 ]] && break; sleep 0.001; done
python3 -c "import json; d=json.load(open('batch/layout.json')); d['links'][0]['name']='replaced'; json.dump(d, open('batch/layout.json','w'))"
wait $p; rc=$?; same=0
for k in $(seq -w 1 70); do cmp -s batchout/r$k/events.jsonl batch1/r01/events.jsonl && same=$((same+1)); done
row B1 "layout replaced mid-batch of 70 recordings" "$( [[ $rc == 0 && $same == 70 ]] && echo pass || echo FAIL)" "exit $rc: $same of 70 recordings gave the events of the layout the batch started with $(tail -1 batch.err)"
cp forearm/layout.json batch/layout.json
out=$($SKIN run batch/rec.toml --recording batch/r01.txt batch/gone.txt batch batch/r02.txt -o batch2 2>&1); rc=$?
row B2 "a batch with a missing recording and a folder" "$( [[ $rc == 1 && ! -e batch2 ]] && echo "$out" | grep -q 'gone.txt (no such file)' && ! echo "$out" | grep -q '^r01' && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1)"
( $SKIN run batch/rec.toml --recording batch/r*.txt -o twob -q >/dev/null 2>&1 & p=$!; sleep 0.3; $SKIN run batch/rec.toml --recording batch/r0*.txt -o twob -q >/dev/null 2>twob.err; echo $? > twob.rc; wait $p; echo $? > twoa.rc )
row H5 "two batches into one folder at once" "$( [[ $(cat twoa.rc) == 0 && $(cat twob.rc) == 1 ]] && [[ -s twob/recordings.tsv ]] && echo pass || echo FAIL)" "first exit $(cat twoa.rc), second exit $(cat twob.rc): $(tail -1 twob.err)"
# ---- Hostile folders
mkdir -p real; ln -sfn real linked
$R -o linked >/dev/null 2>&1; rc1=$?; $R -o linked >/dev/null 2>&1; rc2=$?
row H3 "a symlinked output folder, twice" "$( [[ $rc1 == 0 && $rc2 == 0 && -L linked ]] && complete real && echo pass || echo FAIL)" "exit $rc1, $rc2; link kept, target complete"
$SKIN run user/run.toml --log long.log -q -o gone >/dev/null 2>gone.err & p=$!
for _ in $(seq 600); do [[ -s gone/.skin-partial/events.jsonl ]] && break; sleep 0.01; done
rm -rf gone; wait $p; rc=$?
row H4 "the output folder deleted by the user mid-run" "$( [[ $rc != 0 && ! -e gone ]] && echo pass || echo FAIL)" "exit $rc: $(tail -1 gone.err); left: $(ls -A gone 2>/dev/null | tr '\n' ' ')"
# ---- Unclear errors, one line naming the user's path
$R -o u10 >/dev/null 2>&1
out=$($R -o u10 --mcap u10 2>&1); rc=$?
row U10 "--mcap equal to -o" "$( [[ $rc == 1 && $(echo "$out" | grep -c .) == 1 ]] && echo "$out" | grep -q 'mcap u10.mcap' && ! echo "$out" | grep -q 'u10/' && echo pass || echo FAIL)" "exit $rc: $(echo "$out" | tail -1)"
check U11 "--mcap /dev/full" "1" "/dev/full.*No space left on device" "" -- $R -o u11 --mcap /dev/full
check U12 "-o a folder whose files cannot be written (file size limit)" "1" "u12/events.jsonl|u12: " '[[ ! -e u12 ]] && ! grep -q skin-partial u12.err' -- bash -c "ulimit -f 4; trap '' XFSZ; $R -o u12 2> u12.err; rc=\$?; cat u12.err >&2; exit \$rc"
echo x > blocker; sed 's#^cache = .*#cache = "'"$W"'/blocker/maps"#' user/run.toml > user/blocked.toml
check U13 "a cache folder that cannot be written" "0" "warning: cannot keep tactile maps" '[[ -s u13/summary.txt ]]' -- $SKIN run user/blocked.toml --log user/session.candump.log -q -o u13
sed 's#^cache = .*#cache = "'"$W"'/u14/cache"#' user/run.toml > user/inside.toml
check U14 "a cache folder inside -o" "1" "inside the output folder.*cache =" '[[ ! -e u14 ]]' -- $SKIN run user/inside.toml --log user/session.candump.log -q -o u14
mkdir -p user/forearm; sed 's#^layout = .*#layout = "forearm"#' user/run.toml > user/folder.toml
check U15 "layout = a folder" "1" "this is a folder" "" -- $SKIN run user/folder.toml --log user/session.candump.log -q -o u15
check U16 "an output name of 255 bytes" "0" "" '[[ -s $(printf "n%.0s" $(seq 250)).json ]]' -- $SKIN flatten L.json -o $(printf "n%.0s" $(seq 250)).json
row L9 "no partial file left anywhere by the runs above (SIGKILL's cleaned by the next run)" "$( [[ -z "$(find . -path ./tfs -prune -o \( -name '*.partial*' -o -name .skin-partial \) -print | grep -v sig)" ]] && echo pass || echo FAIL)" "$(find . -path ./tfs -prune -o \( -name '*.partial*' -o -name .skin-partial \) -print | head -3 | tr '\n' ' ')"
echo
echo "scratch: $W"
