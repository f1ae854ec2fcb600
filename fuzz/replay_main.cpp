/// @file replay_main.cpp
/// @brief Runs a fuzz target without libFuzzer:
///
///     fuzz_TARGET_replay [--mutants N] FILE|DIR...
///
/// runs LLVMFuzzerTestOneInput on every file given (a folder: every file in
/// it, in name order) and, with `--mutants N`, on N deterministic mutants of
/// each (Mutate.h; mutant k of file F has the seed hash(name of F) + k). The
/// target aborts on an invariant violation, so the exit status says whether
/// every input passed; before each input runs it is written to
/// `last-fuzz-input` in the working folder, so the one that aborted is kept.
/// The unit suite replays fuzz/regressions/TARGET/ (inputs that once failed)
/// and runs a fixed number of mutants of fuzz/corpus/TARGET/ this way.

#include "Mutate.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

bool readBytes(const std::filesystem::path& file, std::vector<std::uint8_t>& bytes) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return true;
}

// Keeps the input about to run, then runs it.
void runOne(const std::vector<std::uint8_t>& bytes) {
  {
    std::ofstream keep("last-fuzz-input", std::ios::binary | std::ios::trunc);
    keep.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  }
  LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
}

}  // namespace

int main(int argc, char** argv) {
  long mutants = 0;
  std::vector<std::filesystem::path> args;
  for (int k = 1; k < argc; ++k) {
    if (std::strcmp(argv[k], "--mutants") == 0 && k + 1 < argc) {
      char* end = nullptr;
      mutants = std::strtol(argv[++k], &end, 10);
      if (*end != '\0' || mutants < 0) {
        std::fprintf(stderr, "replay: --mutants needs a count >= 0, got '%s'\n", argv[k]);
        return 2;
      }
    } else {
      args.emplace_back(argv[k]);
    }
  }
  if (args.empty()) {
    std::fprintf(stderr, "usage: %s [--mutants N] FILE|DIR...\n", argv[0]);
    return 2;
  }
  int failed = 0, count = 0;
  long mutated = 0;
  for (const std::filesystem::path& arg : args) {
    std::vector<std::filesystem::path> files;
    if (std::filesystem::is_directory(arg)) {
      for (const auto& e : std::filesystem::directory_iterator(arg)) {
        if (e.is_regular_file()) files.push_back(e.path());
      }
      std::sort(files.begin(), files.end());
    } else {
      files.push_back(arg);
    }
    for (const auto& f : files) {
      std::vector<std::uint8_t> bytes;
      if (!readBytes(f, bytes)) {
        std::fprintf(stderr, "replay: cannot read %s\n", f.string().c_str());
        ++failed;
        continue;
      }
      std::printf("replay %s (%zu bytes)%s\n", f.string().c_str(), bytes.size(),
                  mutants > 0 ? (" and " + std::to_string(mutants) + " mutants").c_str() : "");
      std::fflush(stdout);
      runOne(bytes);
      ++count;
      const std::uint64_t seed = lsdem::fuzz::stableHash(f.filename().string());
      for (long m = 0; m < mutants; ++m) {
        runOne(lsdem::fuzz::mutate(bytes, seed + std::uint64_t(m)));
        ++mutated;
      }
    }
  }
  std::printf("replayed %d inputs and %ld mutants\n", count, mutated);
  return failed == 0 && count > 0 ? 0 : 1;
}
