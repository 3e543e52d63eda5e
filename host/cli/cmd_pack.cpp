// `bsdfmix pack MIXTURE -o OUT --storage S`: the same mixtures in another storage (ragged,
// float32 rgb_scale): the bytes a user ships, the file's and the payload's; --interpolation
// sets how slices are interpolated.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "io/mixture_file.hpp"

namespace bsdfmix::cli {

void add_pack(CLI::App& app, Common& common) {
  struct Args {  // the options, kept alive by the callback
    std::string mixture, output, storage = "ragged_f32", interpolation;
  };
  const auto args = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "pack", "write a mixture file's mixtures again in another storage: padded or ragged component arrays, "
              "rgb_scale as float64 or float32 (docs/formats.md, \"Storage\")");
  sub->add_option("mixture", args->mixture, "mixture file (HDF5)")->required()->check(existing_file());
  sub->add_option("-o,--output", args->output, "the packed mixture file")->required();
  sub->add_option("--storage", args->storage,
                  "component arrays padded to the largest K or ragged; rgb_scale float64 or float32 (_f32)")
      ->check(CLI::IsMember({"padded", "ragged", "padded_f32", "ragged_f32"}));
  sub->add_option("--interpolation", args->interpolation,
                  "between fitted slices: blend (mix the two slices' mixtures) or displace (move matched "
                  "components); default: as the file has it (docs/formats.md, \"Interpolation between slices\")")
      ->check(CLI::IsMember({"blend", "displace"}));
  add_common_options(*sub, common);
  sub->callback([args] {
    MixtureFile m = read_mixture_file(args->mixture);
    const std::uint64_t before = m.payload_bytes();
    m.storage = parse_storage(args->storage, "--storage");
    if (!args->interpolation.empty()) m.interpolation = parse_interpolation(args->interpolation, "--interpolation");
    prepare_output(args->output);
    write_mixture_file(args->output, m);
    // the payload stays last on the line: scripts read the bytes after the last "->"
    std::printf("pack %s -> %s (%s): file %llu -> %llu bytes, payload %llu -> %llu bytes\n", args->mixture.c_str(),
                args->output.c_str(), storage_name(m.storage).c_str(),
                static_cast<unsigned long long>(std::filesystem::file_size(args->mixture)),
                static_cast<unsigned long long>(std::filesystem::file_size(args->output)),
                static_cast<unsigned long long>(before), static_cast<unsigned long long>(m.payload_bytes()));
    std::fflush(stdout);
  });
}

}  // namespace bsdfmix::cli
