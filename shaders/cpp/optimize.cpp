// Runs a list of spirv-opt passes over a module with SPIRV-Tools' C++
// optimizer, which the linked shaderc archive already holds (its C API for
// pass lists, spvOptimizerCreate, is newer than Debian's SPIRV-Tools
// 2023.1). Called from shaders/src/lib.rs; the list is
// options::PASSES (docs/performance.md, "The shaders' build").

#include <spirv-tools/optimizer.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

extern "C" {

// The words of the optimised module go to `sink(context, words, count)`,
// the optimizer's messages to `report(context, text)`. Returns 0 on
// success, 1 for a flag the optimizer does not know, 2 when a pass or the
// validator fails, 3 for an exception.
int isomarch_spirv_optimize(const uint32_t* words, size_t count, const char* const* flags, size_t flag_count, int validate, void* context,
                            void (*sink)(void*, const uint32_t*, size_t), void (*report)(void*, const char*)) {
    try {
        spvtools::Optimizer optimizer(SPV_ENV_VULKAN_1_2);
        optimizer.SetMessageConsumer([&](spv_message_level_t level, const char*, const spv_position_t&, const char* message) {
            if (level <= SPV_MSG_ERROR) {
                report(context, message);
            }
        });
        std::vector<std::string> list(flags, flags + flag_count);
        if (!optimizer.RegisterPassesFromFlags(list)) {
            return 1;
        }
        std::vector<uint32_t> result;
        spvtools::OptimizerOptions options;
        options.set_run_validator(validate != 0);
        if (!optimizer.Run(words, count, &result, options)) {
            return 2;
        }
        sink(context, result.data(), result.size());
        return 0;
    } catch (...) {
        return 3;
    }
}
}
