// splitray: one program, one subcommand per job. Errors end here: CLI11's own (usage,
// bad values) through app.exit, splitray::Error as "splitray: <message>" and exit code 1.
#include <fmt/core.h>

#include <cstdio>
#include <exception>
#include <new>

#include "commands.hpp"
#include "file_options.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/memory_budget.hpp"
#include "splitray/dist/world.hpp"

namespace {

// Under mpirun an error every rank knows of is printed by rank 0 only, and a rank that failed
// alone ends the job rather than leaving the others waiting for it.
int fail(const std::exception& error, const char* message) {
  std::fflush(stdout);
  if (splitray::dist::prints_error(error)) fmt::print(stderr, "splitray: {}\n", message);
  std::fflush(stderr);
  splitray::dist::end_after_error(error);
  return 1;
}

// --max-memory on every command (and every command of a command): the budget of
// splitray/core/memory_budget.hpp that declared counts, decompression and ray counts are
// checked against.
void add_memory_option(CLI::App& command) {
  for (CLI::App* sub : command.get_subcommands({})) {
    sub->add_option_function<std::string>(
           "--max-memory",
           [](const std::string& text) {
             splitray::set_memory_budget(splitray::parse_memory_size(text, "--max-memory"));
           },
           "Memory budget for inputs, decompression and ray or query counts (K, M, G "
           "suffixes; default: half of what the machine gives this process, now " +
               splitray::memory_size_text(static_cast<double>(splitray::memory_budget())) + ")")
        ->type_name("SIZE");
    add_memory_option(*sub);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "splitray: spatial subdivision hierarchies (SAH kd-trees and friends) and a CPU ray "
      "tracer.\nRun 'splitray COMMAND --help' for the options of a command.",
      "splitray"};
  app.set_version_flag("-V,--version", "splitray " SPLITRAY_VERSION, "Print the version and exit");
  app.require_subcommand(1);
  app.option_defaults()->always_capture_default();
  app.footer(
      "Errors are printed as 'splitray: <message>' with exit code 1; usage errors exit "
      "with CLI11's codes (non-zero).");

  splitray::app::add_render_command(app);
  splitray::app::add_build_command(app);
  splitray::app::add_trace_command(app);
  splitray::app::add_knn_command(app);
  splitray::app::add_bench_command(app);
  splitray::app::add_animate_command(app);
  splitray::app::add_view_command(app);
  splitray::app::add_train_command(app);
  splitray::app::add_completion_command(app);
  splitray::cli::check_outputs_before_running(app);  // -o equal to an input, a link, a FIFO...
  add_memory_option(app);

  try {
    // Name an unknown command rather than only saying that a command is required.
    if (argc > 1 && argv[1][0] != '-') {
      bool known = false;
      for (const CLI::App* command : app.get_subcommands({}))
        known = known || command->check_name(argv[1]);
      if (!known) throw CLI::ExtrasError({argv[1]});
    }
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const splitray::Error& e) {
    return fail(e, e.what());
  } catch (const std::bad_alloc& e) {
    return fail(e, "out of memory");
  } catch (const std::exception& e) {
    return fail(e, e.what());
  }
  return 0;
}
