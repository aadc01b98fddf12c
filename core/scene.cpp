#include "core/scene.h"

namespace goo {

std::string_view to_string(IntegratorKind kind) {
  return kind == IntegratorKind::newmark ? "newmark" : "backward_euler";
}

}  // namespace goo
