# Sourced by the other scripts: installs what isomarch needs on Debian
# (idempotent, as root or with sudo), then sets the environment for building
# and for running on lavapipe, Mesa's CPU Vulkan driver.

set -euo pipefail

ISOMARCH_PACKAGES=(
    mesa-vulkan-drivers libvulkan1   # lavapipe and the Vulkan loader
    vulkan-validationlayers          # the tests run with validation on
    xvfb xdotool x11-apps            # window tests: a display, input sent to it, xwd to grab what it shows
    libx11-6 libx11-xcb1 libxcursor1 libxi6 libxrandr2 libxkbcommon-x11-0  # loaded by the window code
    libshaderc-dev glslang-dev       # shaderc and glslang as static archives, linked in seconds (isomarch_shaderc_archive)
    cmake python3 g++ git            # the source build of shaderc, where those archives cannot be merged
    python3-venv                     # the Python package's tests (scripts/python-test.sh)
    glslang-tools spirv-tools vulkan-tools  # inspection: glslangValidator, spirv-dis, vulkaninfo
    ca-certificates curl pkg-config
    fonts-dejavu-core                # the font of `isomarch tradeoff`'s plots
)

# Optional package sets, named in ISOMARCH_WITH (space-separated) by the
# script that sources this file: `slurm` is a one-node SLURM with its
# authentication (scripts/slurm-local.sh; the test suite's SLURM test).
# `movie` is ffmpeg, which `render -o movie.mp4`/`.webm` and `encode` hand
# their frames to, and whose ffprobe the movie tests read them back with:
# the test suite's, not the first picture's (its minutes count, and a
# PNG needs no encoder). `lint` is rustfmt and clippy (rustup components;
# the test suite checks formatting and lints first). `fuzz` is cargo-fuzz
# (scripts/fuzz.sh).
ISOMARCH_PACKAGES_SLURM=(slurm-wlm munge)
ISOMARCH_PACKAGES_MOVIE=(ffmpeg)
ISOMARCH_COMPONENTS=()
ISOMARCH_CARGO_TOOLS=()
for _isomarch_set in ${ISOMARCH_WITH:-}; do
    case "$_isomarch_set" in
        slurm) ISOMARCH_PACKAGES+=("${ISOMARCH_PACKAGES_SLURM[@]}") ;;
        movie) ISOMARCH_PACKAGES+=("${ISOMARCH_PACKAGES_MOVIE[@]}") ;;
        lint) ISOMARCH_COMPONENTS+=(rustfmt clippy) ;;
        fuzz) ISOMARCH_CARGO_TOOLS+=(cargo-fuzz) ;;
        *) echo "isomarch: ISOMARCH_WITH names an unknown package set $_isomarch_set (known: slurm, movie, lint, fuzz)" >&2; exit 1 ;;
    esac
done

isomarch_install_packages() {
    local missing=()
    for p in "${ISOMARCH_PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
    done
    if ((${#missing[@]})); then
        local sudo=""
        [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "isomarch: installing ${missing[*]}" >&2
        # Wait for another apt (another script, unattended upgrades) rather than fail.
        $sudo apt-get -o DPkg::Lock::Timeout=600 update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}" >&2
    fi
    if ! command -v cargo >/dev/null 2>&1; then
        if [ -x "$HOME/.cargo/bin/cargo" ]; then
            export PATH="$HOME/.cargo/bin:$PATH"
        else
            echo "isomarch: installing the Rust toolchain with rustup" >&2
            curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal >&2
            export PATH="$HOME/.cargo/bin:$PATH"
        fi
    fi
    local component
    for component in ${ISOMARCH_COMPONENTS[@]+"${ISOMARCH_COMPONENTS[@]}"}; do
        local probe="$component"
        [ "$component" = rustfmt ] && probe=fmt
        if ! cargo "$probe" --version >/dev/null 2>&1; then
            if ! command -v rustup >/dev/null 2>&1; then
                echo "isomarch: cargo $probe is missing and there is no rustup to add the $component component; install it with your Rust toolchain" >&2
                exit 1
            fi
            echo "isomarch: adding the Rust component $component" >&2
            rustup component add "$component" >&2
        fi
    done
    local tool
    for tool in ${ISOMARCH_CARGO_TOOLS[@]+"${ISOMARCH_CARGO_TOOLS[@]}"}; do
        if ! cargo "${tool#cargo-}" --version >/dev/null 2>&1; then
            echo "isomarch: installing $tool" >&2
            cargo install --locked "$tool" >&2
        fi
    done
}

isomarch_install_packages

ISOMARCH_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export ISOMARCH_ROOT

# Merges Debian's static shaderc, glslang, SPIRV-Tools and libstdc++ into one
# archive, .shaderc/libshaderc_combined.a, where .cargo/config.toml points
# shaderc-sys: linking it takes seconds, building shaderc from source about 8
# minutes. One archive, because the linker rescans a single archive until
# nothing new resolves, and glslang's libraries reference each other; and
# libstdc++ inside it, because shaderc-sys asks for no C++ runtime when it
# links a prebuilt library. Debian's own libshaderc.so is underlinked (its
# glslang symbols are undefined), hence the archives. Written to a temporary
# name and renamed, so an interrupted merge leaves nothing half-written; if
# an archive is missing, no folder is made and cargo builds shaderc from
# source as before.
isomarch_shaderc_archive() {
    local dir="$ISOMARCH_ROOT/.shaderc" lib=/usr/lib/x86_64-linux-gnu
    [ -f "$dir/libshaderc_combined.a" ] && return 0
    [ -n "${SHADERC_LIB_DIR:-}" ] && return 0
    local stdcxx archives=() a
    stdcxx=$(g++ -print-file-name=libstdc++.a 2>/dev/null || true)
    for a in shaderc_combined glslang MachineIndependent GenericCodeGen OSDependent OGLCompiler SPIRV \
        glslang-default-resource-limits HLSL SPIRV-Tools-opt SPIRV-Tools; do
        archives+=("$lib/lib$a.a")
    done
    archives+=("$stdcxx")
    for a in "${archives[@]}"; do
        if [ ! -f "$a" ]; then
            echo "isomarch: $a is missing; shaderc will be built from source (about 8 minutes)" >&2
            return 0
        fi
    done
    mkdir -p "$dir"
    local tmp="$dir/.libshaderc_combined.a.$$"
    { echo "CREATE $tmp"; printf 'ADDLIB %s\n' "${archives[@]}"; echo SAVE; echo END; } | ar -M
    mv "$tmp" "$dir/libshaderc_combined.a"
}
isomarch_shaderc_archive
# One target dir outside the clone, kept across clones and CI runs, so that
# shaderc (about 8 minutes from source on 2 cores) is built once.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/isomarch-target}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/isomarch-runtime-$(id -u)}"
mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
# Pin lavapipe unless the caller chose a driver (ISOMARCH_ANY_DRIVER=1 keeps
# every installed driver, for machines with a GPU).
if [ -z "${ISOMARCH_ANY_DRIVER:-}" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
    lvp=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n 1 || true)
    if [ -z "$lvp" ]; then
        echo "isomarch: lavapipe's ICD file is missing from /usr/share/vulkan/icd.d (package mesa-vulkan-drivers)" >&2
        exit 1
    fi
    export VK_DRIVER_FILES="$lvp" VK_ICD_FILENAMES="$lvp"
fi
