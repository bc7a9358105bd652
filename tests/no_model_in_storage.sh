#!/bin/sh
# storage/ stores the model's values but holds no model code (docs/storage.md): its sources include
# no header but its own (gearwatch/storage/...) and the value types' (gearwatch/types/...); the value
# types include none but their own, so no model header comes in through them; and storage's
# CMakeLists links no gearwatch library but the value types. Known exceptions: none.
# Usage: no_model_in_storage.sh SOURCE_DIR
set -eu
cd "$1"
status=0
report() {  # report TITLE FOUND
  echo "$1"
  echo "$2"
  status=1
}
sources='--include=*.cpp --include=*.hpp --include=*.h --include=*.cc'
# An include naming a directory (local includes such as "stored_rows.hpp" name none).
if found=$(grep -rnE $sources '^[[:space:]]*#[[:space:]]*include[[:space:]]*["<]gearwatch/' storage |
           grep -vE '["<]gearwatch/(storage|types)/'); then
  report "storage/ includes a header of the model (store its values through a gearwatch/types/ header):" "$found"
fi
if found=$(grep -rnE $sources '^[[:space:]]*#[[:space:]]*include[[:space:]]*["<]gearwatch/' core/types |
           grep -vE '["<]gearwatch/types/'); then
  report "core/types/ includes a header outside the value types (storage would see the model through it):" "$found"
fi
if found=$(sed 's/#.*//' storage/CMakeLists.txt | grep -noE '\bgearwatch_[a-z_]+' | grep -vE ':(gearwatch_storage|gearwatch_types)$'); then
  report "storage/CMakeLists.txt names a gearwatch library other than gearwatch_types:" "$(echo "$found" | sed 's/^/storage\/CMakeLists.txt:/')"
fi
[ "$status" -eq 0 ] && echo "storage/ includes and links no model code"
exit "$status"
