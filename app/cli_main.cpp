// greybench-cli: the command line of docs/user-guide.md, section 4. The options are parsed and
// dispatched in app/cli/main.cpp; the commands live in app/cli/, the work in core/.
#include "app/cli/cli.h"

int main(int argc, char** argv) { return gb::cli::Main(argc, argv); }
