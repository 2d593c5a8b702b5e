#!/usr/bin/env bash
# Grid scenarios for `trafficmesh bench vs-sumo`, made with SUMO's own tools
# (netgenerate, randomTrips.py from the eclipse-sumo PyPI package).
#
#   configs/sumo/make_scenarios.sh [OUT_DIR]      (default out/sumo-scenarios)
#
# Writes grid{1k,10k,50k}.net.xml and .rou.xml, grid3_crossings.net.xml
# with its two demands, and rand_priority.net.xml / rand_rbl.net.xml
# (netgenerate's random networks: unsignalised junctions at every angle,
# roads that cross with no junction, for random traffic). The grids are
# signalised (200 m blocks, two lanes per direction, no U-turns), with random
# routed trips for 900 s,
# sized for about 1,000, 10,000 and 50,000 vehicles running at once
# (insertion rate x mean trip time). Then, for example:
#   trafficmesh bench vs-sumo --net OUT/grid1k.net.xml --routes OUT/grid1k.rou.xml --duration 900
set -euo pipefail
OUT="${1:-out/sumo-scenarios}"
VENV="${TRAFFICMESH_VENV:-$HOME/.cache/trafficmesh-venv}"
if ! "$VENV/bin/python" -c "import sumo" >/dev/null 2>&1; then
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install --quiet eclipse-sumo==1.28.0
fi
SUMO_HOME="$("$VENV/bin/python" -c 'import sumo, os; print(os.path.dirname(sumo.__file__))')"
export SUMO_HOME
mkdir -p "$OUT"

# name, junctions per side, seconds between departures (randomTrips --period)
for scenario in "grid1k 10 0.25" "grid10k 30 0.03" "grid50k 60 0.008"; do
  set -- $scenario
  name=$1 size=$2 period=$3
  echo "$name: ${size}x${size} grid, a departure every ${period} s"
  "$VENV/bin/netgenerate" --grid --grid.number "$size" --grid.length 200 -L 2 \
    --tls.guess true --no-turnarounds true -o "$OUT/$name.net.xml" >/dev/null
  "$VENV/bin/python" "$SUMO_HOME/tools/randomTrips.py" -n "$OUT/$name.net.xml" \
    -r "$OUT/$name.rou.xml" -o "$OUT/$name.trips.xml" -b 0 -e 900 -p "$period" \
    --seed 42 --fringe-factor 5 >/dev/null
done
# The small grid with sidewalks and pedestrian crossings that the import tests
# read (committed as configs/sumo/grid3_crossings.net.xml).
"$VENV/bin/netgenerate" --grid --grid.number 3 --grid.length 200 -L 2 --tls.guess true \
  --no-turnarounds true --sidewalks.guess true --crossings.guess true \
  -o "$OUT/grid3_crossings.net.xml" >/dev/null
# Its demands (committed as configs/sumo/grid3_crossings{,_saturated}.rou.xml):
# a departure every 2 s and every 1.5 s for 600 s.
for scenario in "grid3_crossings 2" "grid3_crossings_saturated 1.5"; do
  set -- $scenario
  "$VENV/bin/python" "$SUMO_HOME/tools/randomTrips.py" -n "$OUT/grid3_crossings.net.xml" \
    -r "$OUT/$1.rou.xml" -o "$OUT/$1.trips.xml" -b 0 -e 600 -p "$2" --seed 7 \
    --fringe-factor 5 >/dev/null
done
# Random networks (one lane each way, priority and right-before-left
# junctions), for `trafficmesh sim --map OUT/rand_priority.net.xml --duration
# 1800 --max-vehicles 300 --check --json`.
for scenario in "rand_priority 7 priority" "rand_rbl 8 right_before_left"; do
  set -- $scenario
  "$VENV/bin/netgenerate" --rand --rand.iterations 200 --seed "$2" --default.lanenumber 1 \
    --rand.max-distance 200 --default-junction-type "$3" -o "$OUT/$1.net.xml" >/dev/null 2>&1
done
echo "wrote $OUT"
