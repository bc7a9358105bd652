# inside.sh — the systemd test's steps, run INSIDE the systemd VM (systemd-vm.sh) by bash as root,
# after gearwatch's .deb was installed with apt-get. run-systemd-test.sh builds the payload:
# cap.log (a `gearwatch simulate` capture), gearwatch-vcan1.toml (the plant's config: vcan1),
# replay.rows (the records of `gearwatch replay` of the same capture, made on the host), iface.
#  1. the package: files where Debian puts them, the config a conffile, the unit's ExecStart the
#     installed binary, the sysctl applied, no dependency on a fixed CAN device unit;
#  2. `systemctl start gearwatch` with vcan1 in /etc/gearwatch/gearwatch.toml: READY in < 20 s;
#  3. every hardening option of the unit in force on the running process (DynamicUser, no
#     capabilities, seccomp, read-only system, private /tmp, inaccessible /home);
#  4. canplayer plays the capture onto vcan1; the watchdog is pinged;
#  5. `systemctl stop`: drains, commits, exit 0; the records equal the replay's, nothing lost;
#  4b. `systemctl reload` (ExecReload: SIGHUP): the same process goes on; an edit that needs a
#     restart is named in the journal and in `systemctl status`, and is not applied;
#  6. a second run: vcan1 is deleted under it and created again — it survives (same pid), reopens
#     with backoff, and the capture then played onto the new vcan1 gives records; SIGKILLed once
#     a record of it is committed (its record in progress and the backlog not yet analysed die
#     with it): systemd restarts gearwatch, nothing committed is lost, integrity ok (the rest of
#     the capture is not played: nothing reads what the restarted process would record);
#  7. `systemd-analyze security`: overall exposure <= 1.0; with the MQTT drop-in the package ships
#     for a daemon that sends itself (Internet families, the broker's address only) <= 1.5.
#  8. the fleet consumer's unit (gearwatch-fleet.service): installed disabled with its conffile
#     fleet.env; started against a database that refuses connections, the hardened process runs
#     the binary as far as the database (its one-line error in the journal, exit 1), is restarted
#     by systemd, and stops; its exposure <= 1.0.
#  9. the MQTT publisher's unit (gearwatch-publisher.service, [mqtt] sender = "publisher"):
#     installed disabled; started with a broker that refuses connections it reaches READY on the
#     daemon's database, counts the failed connections, stops with exit 0 and stores its final
#     counters in publisher_health; its exposure <= 1.0 with IP, the daemon's without IP.
# Prints what it measured and "SYSTEMD TEST: PASS ..." or "SYSTEMD TEST: FAIL: <reason>".
set -u
P=/payload
unit=gearwatch.service
state=/var/lib/private/gearwatch         # DynamicUser's StateDirectory, as root sees it
db=$state/gearwatch.db
READY_LIMIT_S=20
EXPOSURE_LIMIT=1.0
MQTT_EXPOSURE_LIMIT=1.5
t_begin=$(date +%s)
step() { echo "systemd-test [+$(( $(date +%s) - t_begin )) s] $*"; }
fail() {
  echo "SYSTEMD TEST: FAIL: $*"
  echo "---- systemctl status gearwatch"
  SYSTEMD_COLORS=0 systemctl status gearwatch --no-pager -n 0
  echo "---- journalctl -u gearwatch (last 40 lines)"
  SYSTEMD_COLORS=0 journalctl -u gearwatch --no-pager -n 40 -o short-monotonic
  exit 1
}
prop() { systemctl show -p "$1" --value $unit; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }
less_than() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a < b) }'; }
# sqlite3 as root on the service's database only while gearwatch runs (its WAL files exist) or
# after a clean stop (none left behind): root never creates files the service could not open.
sql() { sqlite3 -batch "$db" "$1"; }
records_query="SELECT start_index, sample_count, end_reason, analysed FROM records ORDER BY start_index"
losses_query="SELECT COALESCE(SUM(kernel_drops + ring_overflows + gaps + malformed_frames), -1) FROM acquisition_health"
wait_for() {  # wait_for SECONDS DESCRIPTION COMMAND...: poll every 0.5 s
  local limit=$1 what=$2; shift 2
  local t0; t0=$(date +%s)
  until "$@"; do
    [ $(( $(date +%s) - t0 )) -lt "$limit" ] || fail "$what: not within $limit s"
    sleep 0.5
  done
}

# --- 1. the package as installed by apt-get
step "systemd $(systemctl --version | head -1 | cut -d' ' -f2), kernel $(uname -r), $(nproc) CPUs"
[ "$(dpkg-query -W -f='${Status}' gearwatch 2>/dev/null)" = "install ok installed" ] || fail "gearwatch is not installed"
step "package: gearwatch $(dpkg-query -W -f='${Version} ${Architecture}' gearwatch); Depends: $(dpkg-query -W -f='${Depends}' gearwatch)"
dpkg-query -L gearwatch >/tmp/package.files
for f in /usr/bin/gearwatch /lib/systemd/system/gearwatch.service /lib/systemd/system/gearwatch-fleet.service /lib/systemd/system/gearwatch-publisher.service /usr/lib/sysctl.d/60-gearwatch.conf \
         /etc/gearwatch/gearwatch.toml /usr/share/doc/gearwatch/README.md; do
  grep -qx "$f" /tmp/package.files || fail "the package does not install $f"
  [ -f "$f" ] || fail "$f is missing after installation"
done
dpkg-query -W -f='${Conffiles}\n' gearwatch | grep -q "^ /etc/gearwatch/gearwatch.toml " ||
  fail "/etc/gearwatch/gearwatch.toml is not a conffile"
exec_path=$(prop ExecStart | sed -n 's/.*path=\([^ ;]*\).*/\1/p')
[ "$exec_path" = /usr/bin/gearwatch ] || fail "ExecStart runs '$exec_path', the package installs /usr/bin/gearwatch"
step "unit $(prop FragmentPath): ExecStart $exec_path"
deps="$(prop After) $(prop Wants) $(prop Requires) $(prop BindsTo)"
case $deps in *sys-subsystem-net-devices*) fail "the unit still depends on a CAN device unit: $deps" ;; esac
rmem=$(cat /proc/sys/net/core/rmem_max)
[ "$rmem" = 16777216 ] || fail "net.core.rmem_max is $rmem: /usr/lib/sysctl.d/60-gearwatch.conf was not applied"
step "net.core.rmem_max = $rmem (from /usr/lib/sysctl.d/60-gearwatch.conf)"

# --- 2. the plant's configuration names vcan1; start
install -m 0644 $P/gearwatch-vcan1.toml /etc/gearwatch/gearwatch.toml
ip -br link show vcan1 | grep -q UP || fail "vcan1 is not up"
t0=$(now)
systemctl start $unit || fail "systemctl start gearwatch failed"
ready_s=$(elapsed "$t0" "$(now)")
[ "$(prop ActiveState)/$(prop SubState)" = active/running ] || fail "gearwatch is $(prop ActiveState)/$(prop SubState) after start"
step "systemctl start returned after ${ready_s} s (Type=notify: READY=1 received); limit ${READY_LIMIT_S} s"
less_than "$ready_s" $READY_LIMIT_S || fail "READY took ${ready_s} s (limit ${READY_LIMIT_S} s)"
wait_for 20 "the journal line 'listening on vcan1'" sh -c "journalctl -u gearwatch -o cat | grep -q 'listening on vcan1'"
step "journal: $(journalctl -u gearwatch -o cat | grep -m1 'listening on vcan1')"
pid=$(prop MainPID)

# --- 3. the hardening of the unit, in force
unitfile=/lib/systemd/system/gearwatch.service
hardening='^(Protect[A-Za-z]+|Private[A-Za-z]+|NoNewPrivileges|Restrict[A-Za-z]+|LockPersonality|MemoryDenyWriteExecute|SystemCallArchitectures|DynamicUser|UMask)='
# What systemd applies, every option from one `systemctl show` (one process per option was slow emulated).
declare -A applied
while IFS='=' read -r key value; do applied[$key]=$value; done < <(
  systemctl show $unit -p "$(grep -E "$hardening" $unitfile | cut -d= -f1 | sort -u | paste -sd, -)")
checked=0
while IFS='=' read -r key value; do
  got=${applied[$key]-}
  if [ "$key" = RestrictAddressFamilies ]; then
    value=$(echo "$value" | tr ' ' '\n' | sort | tr '\n' ' '); got=$(echo "$got" | tr ' ' '\n' | sort | tr '\n' ' ')
  fi
  [ "$got" = "$value" ] || fail "$key: the unit says '$value', systemd applies '$got'"
  checked=$((checked + 1))
done < <(grep -E "$hardening" $unitfile)
[ "$checked" -ge 18 ] || fail "only $checked hardening options found in $unitfile"
status=/proc/$pid/status
uid=$(awk '/^Uid:/ { print $2 }' $status)
[ "$uid" -ge 61184 ] && [ "$uid" -le 65519 ] || fail "gearwatch runs as uid $uid, not a dynamic user (61184..65519)"
for want in "NoNewPrivs:	1" "Seccomp:	2" "CapInh:	0000000000000000" "CapPrm:	0000000000000000" \
            "CapEff:	0000000000000000" "CapBnd:	0000000000000000" "CapAmb:	0000000000000000"; do
  grep -qx "$want" $status || fail "/proc/$pid/status: expected '$want', got '$(grep "^${want%%:*}:" $status)'"
done
inns() { nsenter -t "$pid" -m -- "$@"; }
inns sh -c 'touch /usr/.gearwatch-probe' 2>/dev/null && fail "ProtectSystem=strict: /usr is writable in the service's namespace"
inns sh -c 'touch /etc/.gearwatch-probe' 2>/dev/null && fail "ProtectSystem=strict: /etc is writable in the service's namespace"
[ "$(inns stat -c %a /home)" = 0 ] || fail "ProtectHome=yes: /home is not inaccessible in the service's namespace"
touch /tmp/.host-only
inns test -e /tmp/.host-only && fail "PrivateTmp=yes: the service sees the host's /tmp"
[ "$(readlink /var/lib/gearwatch)" = private/gearwatch ] || fail "/var/lib/gearwatch is not DynamicUser's link to private/gearwatch"
step "hardening in force: $checked options as in the unit; uid $uid (dynamic) $(awk '/^Uid:/ { print $2 "/" $3 }' $status), NoNewPrivs 1, seccomp filter, no capabilities, / and /etc read-only, /home inaccessible, private /tmp"

# --- 4. the capture onto vcan1, the watchdog
frames=$(wc -l <$P/cap.log)
step "canplayer: $frames frames, $(cat $P/iface)"
t0=$(now)
canplayer -I $P/cap.log "$(cat $P/iface)" || fail "canplayer failed"
play_s=$(elapsed "$t0" "$(now)")
step "canplayer done in ${play_s} s"
[ "$(prop ActiveState)" = active ] && [ "$(prop MainPID)" = "$pid" ] || fail "gearwatch did not survive the capture"
[ "$(prop WatchdogUSec)" = 30s ] || fail "WatchdogUSec is $(prop WatchdogUSec), the unit says 30s"
since_ready=$(( ($(prop WatchdogTimestampMonotonic) - $(prop ActiveEnterTimestampMonotonic)) / 1000000 ))
running=$(( ($(cut -d' ' -f1 /proc/uptime | cut -d. -f1) * 1000000 - $(prop ActiveEnterTimestampMonotonic)) / 1000000 ))
step "watchdog: last WATCHDOG=1 at $(prop WatchdogTimestamp), ${since_ready} s after READY (running ${running} s; WatchdogSec 30 s)"
[ "$since_ready" -ge 10 ] || fail "no watchdog ping seen since READY (last ${since_ready} s after it)"

# --- 4b. systemctl reload: SIGHUP, the same process, a change that needs a restart is named
cfg=/etc/gearwatch/gearwatch.toml
cp $cfg /tmp/plant.toml
sed -i 's/^min_length_s = 1.0$/min_length_s = 2.0/' $cfg
grep -q '^min_length_s = 2.0$' $cfg || fail "could not edit records.min_length_s in $cfg for the reload check"
systemctl reload $unit || fail "systemctl reload gearwatch failed"
wait_for 20 "the reload in the journal" sh -c "journalctl -u gearwatch -o cat | grep -q 'SIGHUP: restart required to apply: records.min_length_s'"
[ "$(prop MainPID)" = "$pid" ] && [ "$(prop ActiveState)" = active ] || fail "gearwatch did not keep running through the reload"
wait_for 10 "systemctl status saying 'restart required to apply: records.min_length_s' (it says '$(prop StatusText)')" \
  sh -c "[ \"\$(systemctl show -p StatusText --value $unit)\" = 'restart required to apply: records.min_length_s' ]"
step "reload: $(journalctl -u gearwatch -o cat | grep -m1 'SIGHUP: restart required')"
cp /tmp/plant.toml $cfg
systemctl reload $unit || fail "second systemctl reload failed"
wait_for 20 "the second reload in the journal" sh -c "[ \$(journalctl -u gearwatch -o cat | grep -c 'SIGHUP: configuration $cfg reloaded; applied: none') -ge 2 ]"
wait_for 10 "systemctl status saying 'running; configuration reloaded'" \
  sh -c "[ \"\$(systemctl show -p StatusText --value $unit)\" = 'running; configuration reloaded' ]"
step "reload with the file restored: status '$(prop StatusText)', pid $(prop MainPID) unchanged"

# --- 5. orderly stop: drain, commit, exit 0; the records of a file replay, nothing lost
# Under emulation the analysis lags the bus by minutes; let it catch up with the records the
# schedule closes (end_reason complete) so that the stop has one record left to close, as on a
# plant, rather than minutes of backlog (TimeoutStopSec=90).
scheduled=$(grep -c '|complete|' $P/replay.rows)
t0=$(now)
wait_for 300 "the $scheduled scheduled records analysed" sh -c "[ \$(sqlite3 -batch $db 'SELECT COUNT(*) FROM records') -ge $scheduled ]"
step "processing caught up with the bus: $scheduled scheduled records stored $(elapsed "$t0" "$(now)") s after the capture ended"
records_before_stop=$(sql "SELECT COUNT(*) FROM records")
t0=$(now)
systemctl stop $unit
stop_s=$(elapsed "$t0" "$(now)")
result=$(prop Result) status_=$(prop ExecMainStatus)
stopped_line=$(journalctl -u gearwatch -o cat | grep 'gearwatch stopped:' | tail -n 1)
step "systemctl stop: ${stop_s} s to drain and commit ($records_before_stop records stored before the stop); Result=$result, exit status $status_"
step "journal: $stopped_line"
[ "$result" = success ] && [ "$status_" = 0 ] || fail "stop: Result=$result ExecMainStatus=$status_ (want success, 0)"
[ -n "$stopped_line" ] || fail "no 'gearwatch stopped:' line in the journal: it did not drain and exit by itself"
journalctl -u gearwatch -o cat | grep -q 'gearwatch.service: Deactivated successfully' ||
  fail "systemd did not log 'Deactivated successfully' (exit status 0) for the stop"
[ -f "$db" ] || fail "no database at $db"
[ "$(stat -c %u "$db")" = "$uid" ] || fail "$db belongs to uid $(stat -c %u "$db"), not the service's dynamic uid $uid"
sql "$records_query" >/tmp/run.rows || fail "sqlite3 on $db"
losses=$(sql "$losses_query")
echo "---- gearwatch under systemd (vcan1): start_index | sample_count | end_reason | analysed"
cat /tmp/run.rows
echo "---- gearwatch replay of the same capture (host): start_index | sample_count | end_reason | analysed"
cat $P/replay.rows
echo "---- acquisition_health (last snapshots)"
sqlite3 -header "$db" "SELECT * FROM acquisition_health" | tail -n 3
n_run=$(wc -l </tmp/run.rows) n_replay=$(wc -l <$P/replay.rows)
[ "$n_replay" -gt 0 ] || fail "the replay has no records: nothing to compare"
cmp -s /tmp/run.rows $P/replay.rows || { diff $P/replay.rows /tmp/run.rows; fail "records differ from the replay's ($n_run vs $n_replay)"; }
[ "$losses" = 0 ] || fail "acquisition_health: kernel_drops + ring_overflows + gaps + malformed_frames = $losses"
step "records: $n_run under systemd = $n_replay of the replay, identical; losses 0; database owned by uid $uid in $state"

# --- 6. the interface removed and created again under a running gearwatch; then SIGKILL with
# work in progress: systemd restarts it, nothing committed is lost
systemctl start $unit || fail "second start failed"
first_pid=$(prop MainPID)
journal_count() { journalctl -u gearwatch -o cat | grep -c "$1"; }
wait_for 20 "the second start listening on vcan1" sh -c "[ \$(journalctl -u gearwatch -o cat | grep -c 'listening on vcan1') -ge 2 ]"
reopened_before=$(journal_count 'socketcan vcan1: reopened after')
ip link del vcan1 || fail "could not delete vcan1"
wait_for 20 "gearwatch noticing vcan1 is gone" sh -c "journalctl -u gearwatch -o cat | grep -q 'socketcan vcan1: .*reopening in'"
step "vcan1 deleted: $(journalctl -u gearwatch -o cat | grep 'socketcan vcan1: .*reopening in' | tail -n 1)"
sleep 4  # a few rounds of the backoff (100 ms doubling) with no interface at all
[ "$(prop ActiveState)" = active ] && [ "$(prop MainPID)" = "$first_pid" ] ||
  fail "gearwatch did not survive the interface's removal ($(prop ActiveState), pid $(prop MainPID))"
ip link add dev vcan1 type vcan && ip link set vcan1 mtu 72 && ip link set up vcan1 || fail "could not create vcan1 again"
wait_for 30 "gearwatch reopening vcan1" sh -c "[ \$(journalctl -u gearwatch -o cat | grep -c 'socketcan vcan1: reopened after') -gt $reopened_before ]"
[ "$(prop MainPID)" = "$first_pid" ] && [ "$(prop NRestarts)" = 0 ] || fail "gearwatch was restarted around the interface's return"
step "vcan1 back: $(journalctl -u gearwatch -o cat | grep 'socketcan vcan1: reopened after' | tail -n 1); same pid $first_pid, NRestarts 0"
canplayer -I $P/cap.log "$(cat $P/iface)" &
player=$!
wait_for 120 "a record of the second run committed (after vcan1 came back)" sh -c "[ \$(sqlite3 -batch $db 'SELECT COUNT(*) FROM records') -gt $n_run ]"
sql "SELECT id, start_index, sample_count, end_reason FROM records ORDER BY id" >/tmp/before-kill.rows
last_id=$(tail -n 1 /tmp/before-kill.rows | cut -d'|' -f1)
t0=$(now)
systemctl kill -s KILL $unit
step "SIGKILL to gearwatch (pid $first_pid) with $(wc -l </tmp/before-kill.rows) records committed"
wait_for 60 "systemd restarting gearwatch" sh -c "[ \"\$(systemctl show -p NRestarts --value $unit)\" = 1 ] &&
  [ \"\$(systemctl show -p ActiveState --value $unit)\" = active ] && [ \"\$(systemctl show -p MainPID --value $unit)\" != $first_pid ]"
restart_s=$(elapsed "$t0" "$(now)")
# No check reads what the restarted process records: the rest of the capture is not played (it
# would only be played and then drained by the stop below).
kill "$player" 2>/dev/null
wait "$player" 2>/dev/null
step "restarted by systemd after ${restart_s} s (RestartSec 5 s): NRestarts $(prop NRestarts), pid $(prop MainPID); canplayer stopped"
integrity=$(sql "PRAGMA integrity_check")
sql "SELECT id, start_index, sample_count, end_reason FROM records WHERE id <= $last_id ORDER BY id" >/tmp/after-kill.rows
[ "$integrity" = ok ] || fail "PRAGMA integrity_check after SIGKILL: $integrity"
cmp -s /tmp/before-kill.rows /tmp/after-kill.rows || { diff /tmp/before-kill.rows /tmp/after-kill.rows; fail "records committed before SIGKILL changed or vanished"; }
systemctl stop $unit
[ "$(prop Result)" = success ] && [ "$(prop ExecMainStatus)" = 0 ] || fail "stop after the restart: Result=$(prop Result), status $(prop ExecMainStatus)"
integrity_final=$(sql "PRAGMA integrity_check")
[ "$integrity_final" = ok ] || fail "PRAGMA integrity_check at the end: $integrity_final"
step "after SIGKILL: integrity_check $integrity, all $(wc -l </tmp/before-kill.rows) committed records intact; $(sql 'SELECT COUNT(*) FROM records') records at the end, integrity_check $integrity_final"

# --- 7. exposure
systemd-analyze security $unit --no-pager >/tmp/security.txt 2>&1
grep '✗' /tmp/security.txt | sed 's/^/  /'
overall=$(grep -m1 'Overall exposure level' /tmp/security.txt)
exposure=$(echo "$overall" | sed -n 's/.*: \([0-9.]*\).*/\1/p')
step "systemd-analyze security: $overall"
[ -n "$exposure" ] || fail "no exposure level in systemd-analyze security's output"
awk -v e="$exposure" -v l=$EXPOSURE_LIMIT 'BEGIN { exit !(e <= l) }' || fail "exposure $exposure > $EXPOSURE_LIMIT"
exposure_of() { systemd-analyze security $unit --no-pager 2>&1 | sed -n 's/.*Overall exposure level.*: \([0-9.]*\).*/\1/p' | head -1; }
dropin=/usr/share/doc/gearwatch/examples/gearwatch-mqtt.conf
[ -f $dropin ] || fail "the package does not install $dropin"
install -D -m 0644 $dropin /etc/systemd/system/gearwatch.service.d/mqtt.conf
systemctl daemon-reload
allow=$(prop IPAddressAllow)
mqtt_exposure=$(exposure_of)
rm -r /etc/systemd/system/gearwatch.service.d
systemctl daemon-reload
case $allow in 127.0.0.1|127.0.0.1/32) ;; *) false ;; esac || fail "the MQTT drop-in's IPAddressAllow= is not applied: '$allow'"
[ "$(exposure_of)" = "$exposure" ] || fail "removing the MQTT drop-in did not restore the unit's exposure"
step "systemd-analyze security with the MQTT drop-in (IPAddressAllow=$allow): $mqtt_exposure"
awk -v e="$mqtt_exposure" -v l=$MQTT_EXPOSURE_LIMIT 'BEGIN { exit !(e <= l) }' || fail "exposure with the MQTT drop-in $mqtt_exposure > $MQTT_EXPOSURE_LIMIT"
# --- 8. the fleet consumer's unit
fleet=gearwatch-fleet.service
[ -f /etc/gearwatch/fleet.env ] || fail "the package does not install /etc/gearwatch/fleet.env"
dpkg-query -W -f='${Conffiles}\n' gearwatch | grep -q "^ /etc/gearwatch/fleet.env " || fail "/etc/gearwatch/fleet.env is not a conffile"
[ "$(systemctl is-enabled $fleet 2>&1)" = disabled ] || fail "$fleet is not installed disabled: $(systemctl is-enabled $fleet 2>&1)"
# Port 1 of loopback refuses at once: the consumer must get as far as connecting to the database.
sed -i 's|--database [^ ]*|--database postgresql://gearwatch@127.0.0.1:1/fleet|' /etc/gearwatch/fleet.env
systemctl start $fleet
fleet_deadline=$(( $(date +%s) + 30 ))
until [ "$(systemctl show -p NRestarts --value $fleet)" -ge 1 ] 2>/dev/null || [ "$(date +%s)" -ge $fleet_deadline ]; do sleep 0.5; done
fleet_restarts=$(systemctl show -p NRestarts --value $fleet)
fleet_journal=$(journalctl -u $fleet --no-pager -o cat)
systemctl stop $fleet
systemctl reset-failed $fleet 2>/dev/null || true
[ "$fleet_restarts" -ge 1 ] || fail "$fleet was not restarted after its failure (NRestarts=$fleet_restarts)"
echo "$fleet_journal" | grep -q 'gearwatch: fleet database: cannot connect: ' || fail "$fleet's journal lacks the database error: $fleet_journal"
echo "$fleet_journal" | grep -q 'status=1/FAILURE' || fail "$fleet did not exit 1: $fleet_journal"
fleet_exposure=$(systemd-analyze security $fleet --no-pager 2>&1 | sed -n 's/.*Overall exposure level.*: \([0-9.]*\).*/\1/p' | head -1)
awk -v e="$fleet_exposure" -v l=$EXPOSURE_LIMIT 'BEGIN { exit !(e <= l) }' || fail "$fleet exposure '$fleet_exposure' > $EXPOSURE_LIMIT"
step "fleet consumer unit: disabled on install, database refused -> exit 1 in the journal, restarted $fleet_restarts time(s), stopped; exposure $fleet_exposure"
# --- 9. the MQTT publisher's unit
publisher=gearwatch-publisher.service
[ "$(systemctl is-enabled $publisher 2>&1)" = disabled ] || fail "$publisher is not installed disabled: $(systemctl is-enabled $publisher 2>&1)"
cp $cfg /tmp/gearwatch.toml.before-publisher
printf '\n[mqtt]\nenabled = true\nsender = "publisher"\nhost = "127.0.0.1"\nport = 1\nreconnect_initial_ms = 100\nreconnect_max_ms = 200\n' >>$cfg
t0=$(now)
systemctl start $publisher || fail "$publisher did not start: $(journalctl -u $publisher --no-pager -o cat | tail -5)"
publisher_ready_s=$(elapsed "$t0" "$(now)")
sleep 2
[ "$(systemctl show -p ActiveState --value $publisher)" = active ] || fail "$publisher is not active after READY"
systemctl stop $publisher
publisher_journal=$(journalctl -u $publisher --no-pager -o cat)
[ "$(systemctl show -p ExecMainStatus --value $publisher)" = 0 ] || fail "$publisher did not exit 0: $publisher_journal"
cp /tmp/gearwatch.toml.before-publisher $cfg
echo "$publisher_journal" | grep -q "publish: delivering .*'s outbox to 127.0.0.1:1" || fail "$publisher's journal lacks its start line: $publisher_journal"
publisher_final=$(sql "SELECT final, mqtt_connect_failures, mqtt_delivered FROM publisher_health ORDER BY id DESC LIMIT 1")
case $publisher_final in 1\|[1-9]*\|0) ;; *) fail "publisher_health's last row is not a final one with failed connections: '$publisher_final'" ;; esac
publisher_exposure=$(systemd-analyze security $publisher --no-pager 2>&1 | sed -n 's/.*Overall exposure level.*: \([0-9.]*\).*/\1/p' | head -1)
awk -v e="$publisher_exposure" -v l=$EXPOSURE_LIMIT 'BEGIN { exit !(e <= l) }' || fail "$publisher exposure '$publisher_exposure' > $EXPOSURE_LIMIT"
step "publisher unit: disabled on install, READY in $publisher_ready_s s, broker refused (final, connect failures, delivered: $publisher_final), stopped with exit 0; exposure $publisher_exposure"
echo "SYSTEMD TEST: PASS: ready in ${ready_s} s on vcan1; reload names what needs a restart; $n_run records = replay, 0 lost; watchdog pinged ${since_ready} s after READY; stop ${stop_s} s, exit 0; vcan1 deleted and re-created: same process reopened it, records went on; SIGKILL -> restarted in ${restart_s} s, integrity ok, nothing committed lost; exposure $exposure ($mqtt_exposure with the MQTT drop-in); fleet unit ok, exposure $fleet_exposure; publisher unit ok, exposure $publisher_exposure; $(( $(date +%s) - t_begin )) s in the VM"
exit 0
