#include "engine/version.hpp"

namespace pt {

const char* version() { return PAPERTEAR_VERSION; }

}  // namespace pt
