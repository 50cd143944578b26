#!/usr/bin/env bash
# The README's main job. Installs dependencies, builds, and runs the shared SLAM core on the real public
# pose graphs in ../shared/data/posegraphs, printing the optimisation statistics of each.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/bootstrap.sh
source deploy/build.sh
data=${SHARED_DATA_DIR:-../shared/data}
echo
echo "== Pose-graph optimisation on real public graphs =="
for graph in vertigo/manhattanOlson3500_olson.g2o vertigo/intel.g2o sesync/intel.g2o sesync/CSAIL.g2o \
             sesync/MIT.g2o sesync/manhattan.g2o vertigo/ringCity.g2o; do
  "$BUILD_DIR/bin/slamtool" optimize "$data/posegraphs/$graph"
done
