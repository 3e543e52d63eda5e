// The stand-in command's steps (host/standin/candidates.cpp), for standin.cpp.
#pragma once

#include "io/mixture_file.hpp"
#include "io/table.hpp"
#include "standin/standin.hpp"

namespace bsdfmix {

// One K cap's fit of every table slice and the seconds it took.
struct CapFit {
  MixtureFile mixture;
  double seconds = 0;
};

// Fits every slice of the table with k_max = cap into the work directory (k<cap>.h5), or
// reads the fit there when it is this table's with the same settings; an interrupted fit
// resumes from its checkpoint.
CapFit fit_all_rows(const StandinOptions& o, const TableMeta& meta, int cap);

// The subset of `fit` on stride_rows(stride), written ragged_f32 to s<stride>_k<cap>.h5
// in the work directory and compared with the table at every slice.
StandinCandidate measure_candidate(const StandinOptions& o, const TableMeta& meta, const CapFit& fit, int stride, int cap);

}  // namespace bsdfmix
