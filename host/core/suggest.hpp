// "did you mean ..." for a mistyped key, option or command: the closest known name by
// edit distance.
#pragma once

#include <string>
#include <vector>

namespace bsdfmix {

// The Levenshtein distance between `a` and `b` (insertions, deletions, substitutions).
std::size_t edit_distance(const std::string& a, const std::string& b);

// The candidate closest to `word`, if it is at most max(2, length / 3) edits away
// (ties: the first); "" when none is that close.
std::string closest_name(const std::string& word, const std::vector<std::string>& candidates);

// " (did you mean 'NAME'?)" for the closest candidate, "" when none is close.
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace bsdfmix
