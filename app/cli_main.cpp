// greybench-cli: see CONTRACT section 4.
#include <cstdio>

int main() {
  std::fprintf(stderr, "greybench-cli: error: no command yet\n");
  return 2;
}
