// The `charts` section: where the charts of the fit and convergence stages go.
#include "config/config.hpp"

namespace bsdfmix {

ChartsSection parse_charts(const ConfigNode& n) {
  ChartsSection c;
  c.dir = n.str("dir");
  return c;
}

}  // namespace bsdfmix
