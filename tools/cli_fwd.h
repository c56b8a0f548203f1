// Forward declarations of the CLI11 classes that command headers name by
// pointer or reference. CLI11 2.1 is header-only and defines namespace-scope
// validator objects, so each translation unit that includes <CLI/CLI.hpp>
// compiles ~120 KB of CLI11 code (~8 CPU s at -O3); only the files that
// build or parse a command line include it (docs/building.md).
#pragma once

namespace CLI {
class App;
class ParseError;
}  // namespace CLI
