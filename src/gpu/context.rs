//! Instance, physical device choice, logical device, queue and allocator.

use std::collections::HashMap;
use std::ffi::{CStr, CString, c_void};
use std::hash::{Hash, Hasher};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::{Context as _, Result, anyhow, bail};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to open the GPU.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable the Khronos validation layer and record its messages. Also
    /// enabled by `ISOMARCH_VALIDATION=1`.
    pub validation: bool,
    /// Pick a device by index in `isomarch info` order or by a substring of
    /// its name; `None` picks discrete, then integrated, then CPU.
    pub device: Option<String>,
    /// Open for presenting to windows of this display (`isomarch view`):
    /// the instance gets the display's surface extensions and the device
    /// `VK_KHR_swapchain`.
    pub present: Option<raw_window_handle::RawDisplayHandle>,
}

/// What `isomarch info` prints about one device.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub kind: String,
    pub api_version: String,
    pub driver: String,
    pub max_storage_buffer_range: u64,
    /// The most texels a buffer view may hold (maxTexelBufferElements).
    pub max_texel_buffer_elements: u64,
    pub max_compute_workgroup_invocations: u32,
    pub max_compute_workgroup_count: [u32; 3],
    pub timestamp_period_ns: f32,
    pub timestamps: bool,
    /// 64-bit floats in shaders (shaderFloat64), enabled where the device
    /// has them: camera rays made on the GPU in the host's f64 arithmetic
    /// (render::frame).
    pub float64: bool,
    /// Subgroup sums in compute shaders (the frame's statistics summed on
    /// the GPU, render::frame).
    pub subgroup_arithmetic: bool,
    /// Subgroup ballots in compute shaders (the tile lists' radix sort,
    /// render::tile_build).
    pub subgroup_ballot: bool,
    /// Lanes of a subgroup.
    pub subgroup_size: u32,
    pub memory_heaps_mib: Vec<u64>,
}

impl DeviceInfo {
    /// Whether the device is a CPU's driver (lavapipe): its "GPU" is the
    /// host's own cores, its workgroups run a few at a time.
    pub fn is_cpu(&self) -> bool {
        self.kind == format!("{:?}", vk::PhysicalDeviceType::CPU)
    }
}

/// The Vulkan device and everything with its lifetime.
///
/// If a fence deadline passes, the GPU may still be using any object, and
/// lavapipe cannot cancel a dispatch: [`Context::mark_hung`] makes every
/// wrapper leak instead of destroying, so the process can report and exit.
pub struct Context {
    // Dropping the entry unloads the Vulkan loader and the driver with it:
    // only done once the device is gone (never while the GPU may be busy).
    entry: ManuallyDrop<ash::Entry>,
    pub instance: ash::Instance,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub info: DeviceInfo,
    allocator: Mutex<Option<Allocator>>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    messages: Arc<Mutex<Vec<String>>>,
    // Boxed so its address, given to the debug callback, never moves (the
    // callback reads an Arc through it: the allocation is not redundant).
    #[allow(clippy::redundant_allocation)]
    _callback_sink: Option<Box<Arc<Mutex<Vec<String>>>>>,
    hung: AtomicBool,
    /// Pipelines are created through this cache, loaded from and saved to
    /// `cache_path` (`~/.cache/isomarch/`, one file per device and driver).
    pub pipeline_cache: vk::PipelineCache,
    cache_path: Option<std::path::PathBuf>,
    /// Every compute pipeline made on this device, with its layouts, by
    /// what it was made from ([`Context::shared_pipeline`]): made once and
    /// shared by every `gpu::ComputePipeline` of the same recipe, and
    /// destroyed with the device.
    pipelines: Mutex<HashMap<PipelineRecipe, SharedPipeline>>,
    /// Held around every use of `queue` that Vulkan requires to be
    /// externally synchronised (submits, presents, waiting for it idle), so
    /// that threads sharing the context (the tests' one device, a window
    /// beside a renderer) may submit at once.
    queue_lock: Mutex<()>,
}

/// What a compute pipeline is made from: its SPIR-V (by a hash of the
/// words and their count), its bindings' numbers and descriptor types, its
/// push-constant bytes and its specialisation constants.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PipelineRecipe {
    spirv_hash: u64,
    spirv_words: usize,
    bindings: Vec<(u32, i32)>,
    push_constant_bytes: u32,
    specialization: Vec<(u32, u32)>,
}

impl PipelineRecipe {
    pub(crate) fn new(spirv: &[u32], bindings: &[(u32, vk::DescriptorType)], push_constant_bytes: u32, specialization: &[(u32, u32)]) -> Self {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        spirv.hash(&mut h);
        PipelineRecipe {
            spirv_hash: h.finish(),
            spirv_words: spirv.len(),
            bindings: bindings.iter().map(|&(i, t)| (i, t.as_raw())).collect(),
            push_constant_bytes,
            specialization: specialization.to_vec(),
        }
    }
}

/// A compute pipeline with the layouts it was made with, owned by the
/// [`Context`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct SharedPipeline {
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
}

fn validation_requested(options: &ContextOptions) -> bool {
    options.validation || std::env::var("ISOMARCH_VALIDATION").is_ok_and(|v| v == "1")
}

fn load_entry() -> Result<ash::Entry> {
    // SAFETY: loading the system Vulkan loader; its initialisation has no
    // preconditions beyond being a well-formed shared library.
    unsafe { ash::Entry::load() }
        .map_err(|e| anyhow!("cannot load the Vulkan loader (libvulkan.so.1): {e}; install libvulkan1 and a driver such as mesa-vulkan-drivers"))
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // Never panic here: this runs inside the driver's call stack.
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // SAFETY: `user` is the boxed Arc owned by the Context, which outlives
    // the messenger; `data` is valid for the duration of the callback.
    let (sink, message) = unsafe {
        let sink = &*(user as *const Arc<Mutex<Vec<String>>>);
        let message =
            if (*data).p_message.is_null() { String::from("(no message)") } else { CStr::from_ptr((*data).p_message).to_string_lossy().into_owned() };
        (sink, message)
    };
    // The layer calls back on the thread that made the offending call:
    // its name (a test's, where tests share one device) says whose it was.
    let thread = std::thread::current();
    let who = thread.name().unwrap_or("unnamed thread");
    if let Ok(mut messages) = sink.lock() {
        messages.push(format!("{severity:?} (on {who}): {message}"));
    }
    vk::FALSE
}

fn describe(instance: &ash::Instance, pd: vk::PhysicalDevice, index: usize) -> DeviceInfo {
    // SAFETY: `pd` was enumerated from `instance`.
    let (props, mem, families, features) = unsafe {
        (
            instance.get_physical_device_properties(pd),
            instance.get_physical_device_memory_properties(pd),
            instance.get_physical_device_queue_family_properties(pd),
            instance.get_physical_device_features(pd),
        )
    };
    let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let v = props.api_version;
    let heaps = mem.memory_heaps[..mem.memory_heap_count as usize].iter().map(|h| h.size >> 20).collect();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
    // SAFETY: `pd` was enumerated from `instance`, a Vulkan 1.2 one.
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let timestamps = props.limits.timestamp_compute_and_graphics == vk::TRUE
        || families.iter().any(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE) && f.timestamp_valid_bits > 0);
    DeviceInfo {
        index,
        name,
        kind: format!("{:?}", props.device_type),
        api_version: format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v)),
        driver: format!("{:#x}", props.driver_version),
        max_storage_buffer_range: u64::from(props.limits.max_storage_buffer_range),
        max_texel_buffer_elements: u64::from(props.limits.max_texel_buffer_elements),
        max_compute_workgroup_invocations: props.limits.max_compute_work_group_invocations,
        max_compute_workgroup_count: props.limits.max_compute_work_group_count,
        timestamp_period_ns: props.limits.timestamp_period,
        timestamps,
        float64: features.shader_float64 == vk::TRUE,
        subgroup_arithmetic: subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(vk::SubgroupFeatureFlags::ARITHMETIC | vk::SubgroupFeatureFlags::BASIC),
        subgroup_ballot: subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(vk::SubgroupFeatureFlags::BALLOT),
        subgroup_size: subgroup.subgroup_size,
        memory_heaps_mib: heaps,
    }
}

fn device_rank(kind: vk::PhysicalDeviceType) -> u32 {
    match kind {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn create_instance(entry: &ash::Entry, validation: bool, present: Option<raw_window_handle::RawDisplayHandle>) -> Result<ash::Instance> {
    let app_name = CString::new("isomarch")?;
    let app =
        vk::ApplicationInfo::default().application_name(&app_name).application_version(1).engine_name(&app_name).api_version(vk::API_VERSION_1_2);
    let mut layers = Vec::new();
    let mut extensions = Vec::new();
    if let Some(display) = present {
        let needed =
            ash_window::enumerate_required_extensions(display).context("this display has no Vulkan surface extension (is it X11 or Wayland?)")?;
        extensions.extend_from_slice(needed);
    }
    if validation {
        // SAFETY: plain enumeration.
        let available = unsafe { entry.enumerate_instance_layer_properties() }.context("listing Vulkan layers")?;
        let found = available.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        if !found {
            bail!("validation requested but {VALIDATION_LAYER:?} is not installed (Debian: apt-get install vulkan-validationlayers)");
        }
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let info = vk::InstanceCreateInfo::default().application_info(&app).enabled_layer_names(&layers).enabled_extension_names(&extensions);
    // SAFETY: all pointers in `info` outlive the call.
    unsafe { entry.create_instance(&info, None) }.context("creating the Vulkan instance (is a Vulkan driver installed?)")
}

/// Lists the Vulkan devices with the limits that matter to isomarch.
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let entry = load_entry()?;
    let instance = create_instance(&entry, false, None)?;
    // SAFETY: the instance is valid and destroyed right after use.
    let result = unsafe { instance.enumerate_physical_devices() }
        .context("enumerating Vulkan devices")
        .map(|pds| pds.iter().enumerate().map(|(i, &pd)| describe(&instance, pd, i)).collect());
    // SAFETY: no object created from the instance survives.
    unsafe { instance.destroy_instance(None) };
    result
}

impl Context {
    /// Opens the chosen device with one compute queue.
    pub fn new(options: &ContextOptions) -> Result<Arc<Context>> {
        let validation = validation_requested(options);
        let entry = load_entry()?;
        let instance = create_instance(&entry, validation, options.present)?;
        let messages = Arc::new(Mutex::new(Vec::new()));
        let mut callback_sink = None;
        let mut debug = None;
        if validation {
            let sink = Box::new(Arc::clone(&messages));
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*sink as *const Arc<Mutex<Vec<String>>> as *mut c_void);
            // SAFETY: the sink box lives in the Context, past the messenger.
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }.context("creating the validation messenger")?;
            debug = Some((loader, messenger));
            callback_sink = Some(sink);
        }

        // SAFETY: the instance is valid.
        let pds = unsafe { instance.enumerate_physical_devices() }.context("enumerating Vulkan devices")?;
        let infos: Vec<DeviceInfo> = pds.iter().enumerate().map(|(i, &pd)| describe(&instance, pd, i)).collect();
        let chosen = match &options.device {
            Some(sel) => {
                let by_index = sel.parse::<usize>().ok().filter(|&i| i < pds.len());
                by_index.or_else(|| infos.iter().position(|d| d.name.to_lowercase().contains(&sel.to_lowercase()))).ok_or_else(|| {
                    let names: Vec<String> = infos.iter().map(|d| format!("{}: {}", d.index, d.name)).collect();
                    anyhow!("--device {sel:?} matches no Vulkan device; available: {}", names.join(", "))
                })?
            }
            None => (0..pds.len())
                .min_by_key(|&i| {
                    // SAFETY: enumerated from this instance.
                    device_rank(unsafe { instance.get_physical_device_properties(pds[i]) }.device_type)
                })
                .ok_or_else(|| anyhow!("no Vulkan device found; install mesa-vulkan-drivers for lavapipe"))?,
        };
        let physical_device = pds[chosen];
        let info = infos[chosen].clone();

        // SAFETY: enumerated from this instance.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical_device) };
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .ok_or_else(|| anyhow!("device {} has no compute queue", info.name))? as u32;
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let device_extensions = if options.present.is_some() { vec![ash::khr::swapchain::NAME.as_ptr()] } else { vec![] };
        let features = vk::PhysicalDeviceFeatures::default().shader_float64(info.float64);
        let device_info =
            vk::DeviceCreateInfo::default().queue_create_infos(&queue_info).enabled_extension_names(&device_extensions).enabled_features(&features);
        // SAFETY: valid physical device and create info.
        let device = unsafe { instance.create_device(physical_device, &device_info, None) }
            .with_context(|| format!("creating a logical device on {}", info.name))?;
        // SAFETY: queue 0 of a family we requested.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .context("creating the GPU memory allocator")?;
        // SAFETY: enumerated from this instance.
        let props = unsafe { instance.get_physical_device_properties(physical_device) };
        let cache_path = pipeline_cache_path(&props);
        // Vulkan drivers check the data's header and ignore data from
        // another device or driver version; a missing or unreadable file
        // just starts an empty cache.
        let initial = cache_path.as_deref().and_then(|p| std::fs::read(p).ok()).unwrap_or_default();
        let cache_info = vk::PipelineCacheCreateInfo::default().initial_data(&initial);
        // SAFETY: valid device; the data is only a hint the driver validates.
        let pipeline_cache = unsafe { device.create_pipeline_cache(&cache_info, None) }
            .or_else(|_| unsafe { device.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None) })
            .context("creating the pipeline cache")?;

        Ok(Arc::new(Context {
            entry: ManuallyDrop::new(entry),
            instance,
            physical_device,
            device,
            queue,
            queue_family,
            info,
            allocator: Mutex::new(Some(allocator)),
            debug,
            messages,
            _callback_sink: callback_sink,
            hung: AtomicBool::new(false),
            pipeline_cache,
            cache_path,
            pipelines: Mutex::new(HashMap::new()),
            queue_lock: Mutex::new(()),
        }))
    }

    /// Writes the pipeline cache to disk (atomically) so that the next run
    /// creates its pipelines faster where the driver keeps compiled code;
    /// returns the bytes written (0: nothing to keep, or no cache folder).
    pub fn save_pipeline_cache(&self) -> Result<usize> {
        let Some(path) = &self.cache_path else { return Ok(0) };
        // SAFETY: a cache of this device.
        let data = unsafe { self.device.get_pipeline_cache_data(self.pipeline_cache) }.context("reading the pipeline cache")?;
        // A bare header (32 bytes, lavapipe's case) holds nothing to keep.
        if data.len() <= 32 {
            return Ok(0);
        }
        crate::output::write_atomic(path, &data)?;
        Ok(data.len())
    }

    /// The pipeline made from `recipe`, made by `make` the first time it
    /// is asked for and shared from then on: pipelines of the same SPIR-V,
    /// bindings and specialisation made by one process (a renderer per
    /// scene, a test's many scenes) are compiled once, and the validation
    /// layer parses their module once. `make` runs without the lock held;
    /// if another thread made the same pipeline meanwhile, its copy is
    /// kept and this one destroyed.
    pub(crate) fn shared_pipeline(&self, recipe: PipelineRecipe, make: impl FnOnce() -> Result<SharedPipeline>) -> Result<SharedPipeline> {
        if let Some(p) = self.pipelines.lock().map_err(|_| anyhow!("pipeline table lock poisoned"))?.get(&recipe) {
            return Ok(*p);
        }
        let made = make()?;
        let mut table = self.pipelines.lock().map_err(|_| anyhow!("pipeline table lock poisoned"))?;
        if let Some(p) = table.get(&recipe) {
            // SAFETY: `made` was never handed out.
            unsafe { self.destroy_shared(made) };
            return Ok(*p);
        }
        table.insert(recipe, made);
        Ok(made)
    }

    /// # Safety
    /// No pending work uses `p`, and nothing will.
    unsafe fn destroy_shared(&self, p: SharedPipeline) {
        // SAFETY: as the caller promises; null handles are no-ops.
        unsafe {
            self.device.destroy_pipeline(p.pipeline, None);
            self.device.destroy_pipeline_layout(p.layout, None);
            self.device.destroy_descriptor_set_layout(p.set_layout, None);
        }
    }

    /// The Vulkan loader's entry points (surface creation needs them).
    pub fn entry(&self) -> &ash::Entry {
        &self.entry
    }

    /// The queue, for as long as the guard lives: take it around every
    /// `vkQueueSubmit`, `vkQueuePresentKHR` and `vkQueueWaitIdle`, which
    /// Vulkan requires to be externally synchronised per queue.
    pub fn lock_queue(&self) -> std::sync::MutexGuard<'_, ()> {
        // A panic while submitting leaves nothing half-made in `()`.
        self.queue_lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether the validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.debug.is_some()
    }

    /// Validation messages recorded so far (warnings and errors).
    pub fn validation_messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    /// Bytes of GPU memory allocated now (buffers and images), and the
    /// bytes of the memory blocks reserved for them.
    pub fn gpu_memory(&self) -> Option<(u64, u64)> {
        let guard = self.allocator.lock().ok()?;
        let report = guard.as_ref()?.generate_report();
        Some((report.total_allocated_bytes, report.total_capacity_bytes))
    }

    /// Runs `f` with the allocator.
    pub(crate) fn with_allocator<T>(&self, f: impl FnOnce(&mut Allocator) -> Result<T>) -> Result<T> {
        let mut guard = self.allocator.lock().map_err(|_| anyhow!("GPU allocator lock poisoned"))?;
        let allocator = guard.as_mut().ok_or_else(|| anyhow!("GPU allocator already destroyed"))?;
        f(allocator)
    }

    /// Records that the GPU may still be executing work we gave up on: from
    /// now on nothing is destroyed, only leaked.
    pub fn mark_hung(&self) {
        self.hung.store(true, Ordering::SeqCst);
    }

    pub fn is_hung(&self) -> bool {
        self.hung.load(Ordering::SeqCst)
    }
}

/// Where the pipeline cache of this device and driver lives: beside the
/// compiled kernels, `$XDG_CACHE_HOME/isomarch` or `~/.cache/isomarch`;
/// `None` without a home.
fn pipeline_cache_path(props: &vk::PhysicalDeviceProperties) -> Option<std::path::PathBuf> {
    let uuid: String = props.pipeline_cache_uuid.iter().map(|b| format!("{b:02x}")).collect();
    Some(isomarch_shaders::user_cache_dir()?.join(format!("pipelines-{:04x}-{:04x}-{uuid}.bin", props.vendor_id, props.device_id)))
}

impl Drop for Context {
    fn drop(&mut self) {
        if self.is_hung() {
            // The allocator's drop would free memory the GPU may be using.
            if let Ok(mut guard) = self.allocator.lock() {
                std::mem::forget(guard.take());
            }
            // The messenger stays alive, so its sink must too.
            std::mem::forget(self._callback_sink.take());
            return;
        }
        // SAFETY: every wrapper holds an Arc<Context>, so none is alive now;
        // waiting idle guarantees the GPU no longer uses their memory.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Ok(mut guard) = self.allocator.lock() {
                drop(guard.take());
            }
            let shared: Vec<SharedPipeline> = self.pipelines.lock().map(|mut t| t.drain().map(|(_, p)| p).collect()).unwrap_or_default();
            for p in shared {
                self.destroy_shared(p);
            }
            self.device.destroy_pipeline_cache(self.pipeline_cache, None);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
            ManuallyDrop::drop(&mut self.entry);
        }
    }
}
