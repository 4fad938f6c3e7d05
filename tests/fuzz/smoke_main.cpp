// Fuzz smoke driver: runs a libFuzzer entry point on N deterministic pseudo-random inputs
// (random lengths, random bytes, and bit-flips of earlier inputs) so CI exercises every wire
// parser without clang's libFuzzer. A crash or sanitizer report fails the test.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  const long iterations = argc > 1 ? std::atol(argv[1]) : 100000;
  std::mt19937_64 rng(0xD21'7E6'3A1ULL);
  std::vector<uint8_t> last;
  for (long i = 0; i < iterations; ++i) {
    std::vector<uint8_t> input;
    if (!last.empty() && (i % 3 == 0)) {
      input = last;  // mutate the previous input: flip 1..4 bits, maybe resize
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int f = 0; f < flips; ++f) input[rng() % input.size()] ^= uint8_t(1u << (rng() % 8));
      if (rng() % 8 == 0) input.resize(rng() % (input.size() + 8));
    } else {
      const size_t len = rng() % 96;
      input.resize(len);
      for (auto& b : input) b = static_cast<uint8_t>(rng());
    }
    LLVMFuzzerTestOneInput(input.data(), input.size());
    last = std::move(input);
  }
  std::printf("fuzz smoke: %ld inputs, no crash\n", iterations);
  return 0;
}
