// Typed errors thrown inside bsdfmix; only the CLI turns them into one line and an exit code.
#pragma once

#include <stdexcept>
#include <string>

namespace bsdfmix {

// Base of every error bsdfmix throws on purpose. what() is one line that names
// what is wrong and where.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Malformed or invalid input data: table, mixture or RGL files, their contents.
struct InputError : Error {
  using Error::Error;
};

// A configuration problem: unknown key, wrong type, impossible value, missing file.
struct ConfigError : Error {
  using Error::Error;
};

// An OpenCL failure: no platform, a failed call, a failed build.
struct DeviceError : Error {
  using Error::Error;
};

// A file-system failure: cannot create, write or rename an output.
struct IoError : Error {
  using Error::Error;
};

// A command or feature that is not available in this build.
struct UnavailableError : Error {
  using Error::Error;
};

}  // namespace bsdfmix
