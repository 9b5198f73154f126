// Runs a list of spirv-opt passes over a module with SPIRV-Tools' C++
// optimizer, which the linked shaderc archive already holds (its C API for
// pass lists, spvOptimizerCreate, is newer than Debian's SPIRV-Tools
// 2023.1). Called from shaders/src/lib.rs; the list is
// options::PASSES (docs/performance.md, "The shaders' build").

#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

extern "C" {

// Runs `flags` over the module `words`, after setting its specialisation
// constants `ids[k]` to the 32-bit patterns `values[k]` where `constants`
// is not 0 (as a driver reads VkSpecializationInfo: bits, whatever the
// constant's type). A module without constants (a kernel shaderc just
// compiled) is validated going in; a specialisation of a kernel already
// validated is validated coming out (a small module, a fraction of the
// time). The words of the result go to `sink(context, words, count)`, the
// messages to `report(context, text)`. Returns 0 on success, 1 for a flag
// the optimizer does not know, 2 when a pass or the input's validation
// fails, 3 for an exception, 4 when the output is not valid.
int isomarch_spirv_optimize(const uint32_t* words, size_t count, const uint32_t* ids, const uint32_t* values, size_t constants,
                            const char* const* flags, size_t flag_count, void* context, void (*sink)(void*, const uint32_t*, size_t),
                            void (*report)(void*, const char*)) {
    try {
        spvtools::Optimizer optimizer(SPV_ENV_VULKAN_1_2);
        auto consumer = [&](spv_message_level_t level, const char*, const spv_position_t&, const char* message) {
            if (level <= SPV_MSG_ERROR) {
                report(context, message);
            }
        };
        optimizer.SetMessageConsumer(consumer);
        if (constants > 0) {
            std::unordered_map<uint32_t, std::vector<uint32_t>> bits;
            for (size_t k = 0; k < constants; ++k) {
                bits[ids[k]] = {values[k]};
            }
            optimizer.RegisterPass(spvtools::CreateSetSpecConstantDefaultValuePass(bits));
        }
        std::vector<std::string> list(flags, flags + flag_count);
        if (!optimizer.RegisterPassesFromFlags(list)) {
            return 1;
        }
        spvtools::OptimizerOptions options;
        options.set_run_validator(constants == 0);
        std::vector<uint32_t> result;
        if (!optimizer.Run(words, count, &result, options)) {
            return 2;
        }
        if (constants > 0) {
            spvtools::SpirvTools tools(SPV_ENV_VULKAN_1_2);
            tools.SetMessageConsumer(consumer);
            if (!tools.Validate(result)) {
                return 4;
            }
        }
        sink(context, result.data(), result.size());
        return 0;
    } catch (...) {
        return 3;
    }
}
}
