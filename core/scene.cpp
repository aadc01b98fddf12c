#include "core/scene.h"

namespace goo {

std::string_view to_string(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::newmark:
      return "newmark";
    case IntegratorKind::backward_euler:
      return "backward_euler";
    case IntegratorKind::statics:
      return "static";
  }
  return "unknown";
}

}  // namespace goo
