#!/bin/bash
# Issue 36's wear target on another gear pair, run as a user would: the lubricated campaign of
# tests/test_another_gearbox_targets.cpp (23/46 teeth, 33 Hz, 25.6 kHz, 8 stops of 2.2 s, pitting
# carriers 3-9 kHz) simulated by the rig, each capture replayed by the daemon, then per record the
# wear verdict, the low-band ICS2 and the speed source (docs/rig-simulator.md).
# usage: tools/campaign_23_46.sh GEARWATCH_BINARY SEED K_PITTING tacho|notacho OUT_DIR
# K_PITTING 0.034 is the test's pitting campaign, 0 the same campaign without pitting.
set -euo pipefail
if [ $# -ne 5 ]; then echo "usage: $0 GEARWATCH_BINARY SEED K_PITTING tacho|notacho OUT_DIR" >&2; exit 2; fi
BIN=$1; SEED=$2; KP=$3; MODE=$4; D=$5
case $MODE in tacho|notacho) ;; *) echo "$0: the fourth argument is tacho or notacho, not '$MODE'" >&2; exit 2;; esac
if [ -e "$D" ]; then echo "$0: $D exists; give a new output directory" >&2; exit 2; fi
mkdir -p "$D"
cat > "$D"/daemon.toml <<T
[gears]
pinion_teeth = 23
gear_teeth = 46
module_mm = 1.5
face_width_mm = 15.0
[rig]
sample_rate_hz = 25600.0
[records]
length_s = 2.0
interval_s = 600.0
min_length_s = 1.0
[[channels]]
number = 0
name = "casing_y"
scale = 0.02
[model]
enabled = false
T
cat > "$D"/lub.toml <<T
[campaign]
name = "lub-23-46"
max_cycles = 3250000.000000
records = 8
seconds = 2.200000
sample_rate_hz = 25600.0
channels = 1
torque_nm = 20.000000
measurement_speeds_hz = [33.000000]
integration_rate_hz = 200000
stop_interval_cycles = 400000
[wear]
law = "archard"
reference_torque_nm = 20.0
pitting_onset_cycles = 300000
k_pitting = $KP
pitting_exponent = 1.5
max_pitting = 0.3
initial_roughness = 1.0
runin_cycles = 80000
roughness_per_um = 0.0
[[wear.phase]]
from_cycles = 0
k_wear = 2.0e-16
[[wear.phase]]
from_cycles = 230000
k_wear = 3.0e-17
[[wear.phase]]
from_cycles = 2300000
k_wear = 6.0e-17
[sliding]
pitting_gain_m_s2 = 20.0
roughness_gain_m_s2 = 0.0
pitting_band_hz = [3000.0, 9000.0]
abrasion_band_hz = [10000.0, 12000.0]
[effects]
enabled = ["noise"]
[effects.noise]
psd = 4.0e-5
T
FLAG=""; if [ "$MODE" = notacho ]; then FLAG=--no-tacho; fi
"$BIN" simulate --campaign "$D"/lub.toml --config "$D"/daemon.toml --seed $SEED $FLAG --out "$D"/cap > "$D"/sim.log 2>&1
for f in "$D"/cap/*.log; do "$BIN" replay "$f" --db "$D"/db.sqlite --config "$D"/daemon.toml >> "$D"/replay.log 2>&1; done
python3 - "$D" <<'P'
import sqlite3,json,sys
d=sys.argv[1]
t=json.load(open(d+'/cap/truth.json'))
onset=next((i for i,r in enumerate(t['records']) if r['pitting_density']>0),-1)
c=sqlite3.connect(d+'/db.sqlite')
mech=[r[0] for r in c.execute("SELECT mechanism FROM wear_mechanism WHERE channel=0 ORDER BY record_id")]
ics=[r[0] for r in c.execute("SELECT value FROM indicators WHERE channel=0 AND name='ics2_low_band' ORDER BY record_id")]
src=[r[0] for r in c.execute("SELECT speed_source FROM records ORDER BY id")]
first=next((i for i,m in enumerate(mech) if m=='fatigue_pitting'),-1)
# Records counted from 1, as in docs/rig-simulator.md; 0 = never.
print(f"{d}: pitting onset at record {onset+1}, fatigue_pitting first named at record {first+1}, "
      f"{first-onset if first>=0 and onset>=0 else 'n/a'} records after the onset")
print(" mech", ' '.join(mech)); print(" ics2_low", ' '.join(f'{v:.4g}' for v in ics)); print(" src", ' '.join(src))
P
