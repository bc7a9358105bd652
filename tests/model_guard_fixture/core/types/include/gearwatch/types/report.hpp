// Fixture of tests/no_model_in_storage.sh: a value-type header that includes a model header.
#include "gearwatch/types/record.hpp"
#include <gearwatch/gap/diagnosis.hpp>
