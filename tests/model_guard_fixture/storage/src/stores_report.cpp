// Fixture of tests/no_model_in_storage.sh: a storage source that includes a model header.
#include "gearwatch/storage/writer.hpp"
#include "gearwatch/wear/updating.hpp"
#include "stored_rows.hpp"
