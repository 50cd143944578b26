# Sourced by tests/scaleout/scaleout_fault_test.sh and bench/upload_load.sh: a fleetd topology on loopback —
# a throwaway PostgreSQL 15 (as storage/tests/test_databases.cc starts it) and fleetd processes — with
# cleanup on exit. The sourcing script sets `bin` (the build's bin directory) and `admin` (the bootstrap
# admin token) and defines `fail MESSAGE`; FLEETD_COMMON_ARGS (an array) is added to every fleetd.
#
#   topology_init PREFIX     a work directory $work (/tmp/PREFIX.XXXXXX), removed with everything on exit
#   start_postgres           sets $port and $db (postgresql://...), defines `sql QUERY`
#   start_fleetd NAME ARGS…  fleetd in the background, logs in $work/NAME.{out,log}; sets $last_pid
#   grpc_of NAME             the gRPC address fleetd NAME printed
pgbin=/usr/lib/postgresql/15/bin
py=/usr/bin/python3; [[ -x $py ]] || py=python3
pids=()
pg_started=
FLEETD_COMMON_ARGS=()

as_postgres() { if ((EUID == 0)); then runuser -u postgres -- "$@"; else "$@"; fi; }
json() { "$py" -c "import json,sys; d=json.load(sys.stdin); print($1)"; }
free_port() { "$py" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

topology_cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  if [[ -n "$pg_started" ]]; then as_postgres "$pgbin/pg_ctl" -D "$work/pg/data" -m immediate -w stop >/dev/null 2>&1 || true; fi
  rm -rf "$work"
}

topology_init() {
  work=$(mktemp -d "/tmp/$1.XXXXXX")
  chmod 755 "$work"  # the postgres user reads its directory below
  trap topology_cleanup EXIT
}

start_postgres() {
  [[ -x $pgbin/initdb ]] || fail "no $pgbin/initdb: run deploy/bootstrap.sh (package postgresql)"
  mkdir -p "$work/pg"
  if ((EUID == 0)); then chown postgres:postgres "$work/pg"; fi
  as_postgres "$pgbin/initdb" -D "$work/pg/data" -U postgres -A trust -E UTF8 --no-locale --no-sync >"$work/pg/initdb.out" 2>&1 ||
    fail "initdb: $(tail -3 "$work/pg/initdb.out")"
  port=$(free_port)
  as_postgres "$pgbin/pg_ctl" -D "$work/pg/data" -l "$work/pg/server.log" -w -t 30 start \
    -o "-c listen_addresses=127.0.0.1 -p $port -k $work/pg -c fsync=off -c max_connections=200" >/dev/null ||
    fail "pg_ctl start: $(tail -3 "$work/pg/server.log")"
  pg_started=1
  as_postgres "$pgbin/createdb" -h 127.0.0.1 -p "$port" -U postgres fleet
  db="postgresql://postgres@127.0.0.1:$port/fleet"
}
sql() { psql -h 127.0.0.1 -p "$port" -U postgres -d fleet -XAtq -c "$1"; }

start_fleetd() {
  local name=$1; shift
  FLEETD_BOOTSTRAP_ADMIN_TOKEN=$admin "$bin/fleetd" --http 127.0.0.1:0 --log-format text "${FLEETD_COMMON_ARGS[@]}" "$@" \
    >"$work/$name.out" 2>"$work/$name.log" &
  last_pid=$!
  pids+=("$last_pid")
  for _ in $(seq 300); do
    [[ -s "$work/$name.out" ]] && return 0
    kill -0 "$last_pid" 2>/dev/null || fail "$name exited at start"
    sleep 0.1
  done
  fail "$name did not start"
}
grpc_of() { head -1 "$work/$1.out" | json 'd["grpc"]'; }
