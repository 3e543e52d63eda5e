// f at a fiber from a full-4D table (no azimuthal symmetry) or from its stand-in
// (docs/render.md, "A full-4D table"): the table memory-mapped (render/mapped_table.hpp),
// the stand-in a mixture file fitted to it. phi_o and phi_i are measured about the fiber's
// tangent t from a reference e1: the patch's normal (+z) made perpendicular to t (+x
// where t lies along z), e2 = t x e1. Directions are still drawn by the render's own
// (azimuthal) table and mixtures; only f comes from here.
#pragma once

#include <bsdfmix/mixture.hpp>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "core/vec3.hpp"
#include "render/mapped_table.hpp"
#include "render/table_bsdf.hpp"

namespace bsdfmix {
namespace render {

struct FullF {
  std::unique_ptr<MappedTable> table;
  mix::MixtureSet set;  // the stand-in, not azimuthal
  std::uint64_t mixture_bytes = 0;
  std::size_t mixture_slices = 0;
  std::string key;  // what the reference depends on: the two files' paths, sizes and times

  // f (luminance) at theta_o, phi_o and theta, phi, all in the fiber's reference frame.
  double f(FSource which, double theta_o, double phi_o, double theta, double phi) const {
    return which == FSource::Table ? table->f(theta_o, phi_o, theta, phi) : set.eval_f(theta_o, phi_o, theta, phi);
  }
};

// The azimuth of w about the unit tangent t, from the reference e1 (above).
inline double reference_phi(const Vec3& t, const Vec3& w) {
  Vec3 e1{-t[2] * t[0], -t[2] * t[1], 1 - t[2] * t[2]};  // z - (z.t) t
  if (dot(e1, e1) < 1e-12) e1 = {1 - t[0] * t[0], -t[0] * t[1], -t[0] * t[2]};
  e1 = normalized(e1);
  const Vec3 e2 = cross(t, e1);
  return std::atan2(dot(w, e2), dot(w, e1));
}

// The table at `table_path` mapped, and the stand-in at `mixture_path`: InputError (one
// line) when the mixture file is not a fiber mixture without symmetry on the table's grid.
std::unique_ptr<FullF> open_full(const std::string& table_path, const std::string& mixture_path);

// Writes `csv` (one row): the table's bytes, the bytes mapped and resident, the process's
// peak RSS, the stand-in's bytes and slices.
void write_full_report(const std::string& csv, const FullF& full);

}  // namespace render
}  // namespace bsdfmix
