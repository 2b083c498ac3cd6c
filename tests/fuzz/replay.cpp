/* Replays committed fuzz inputs through a target's LLVMFuzzerTestOneInput
 * without libFuzzer, so every build (gcc too) re-checks the seed corpus and
 * each crash found so far. Arguments: files or directories (read
 * recursively, in sorted order). A broken invariant aborts; otherwise the
 * last line counts the inputs like the core tests do. */
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput (const uint8_t * data, size_t size);
extern "C" int LLVMFuzzerInitialize (int *argc, char ***argv)
    __attribute__((weak));

namespace fs = std::filesystem;

int
main (int argc, char **argv)
{
  if (LLVMFuzzerInitialize)
    LLVMFuzzerInitialize (&argc, &argv);
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; i++) {
    const fs::path p (argv[i]);
    if (!fs::exists (p))
      continue;                 /* e.g. no regression inputs yet */
    if (fs::is_directory (p)) {
      for (const auto & e : fs::recursive_directory_iterator (p))
        if (e.is_regular_file ())
          inputs.push_back (e.path ());
    } else {
      inputs.push_back (p);
    }
  }
  std::sort (inputs.begin (), inputs.end ());
  if (inputs.empty ()) {
    fprintf (stderr, "no inputs to replay\n");
    return 1;
  }
  int done = 0;
  for (const auto & p : inputs) {
    std::ifstream f (p, std::ios::binary);
    if (!f) {
      fprintf (stderr, "cannot read %s\n", p.c_str ());
      return 1;
    }
    const std::vector<char> bytes ((std::istreambuf_iterator<char> (f)),
        std::istreambuf_iterator<char> ());
    printf ("%s (%zu bytes)\n", p.c_str (), bytes.size ());
    fflush (stdout);
    LLVMFuzzerTestOneInput ((const uint8_t *) bytes.data (), bytes.size ());
    done++;
  }
  printf ("%d passed, 0 failed\n", done);
  return 0;
}
