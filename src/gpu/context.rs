//! The wgpu device: adapter selection, buffers (uniforms laid out by encase from their
//! `ShaderType` structs), pipelines, dispatch sizes and readback.

use super::bytes::{Access, BindingUse, Cost, pass_model};
use super::profile::Profiler;
use bytemuck::Pod;
use encase::ShaderType;
use encase::internal::WriteInto;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::sync::Mutex;
use thiserror::Error;
use wgpu::util::DeviceExt;

/// Environment variable that picks an adapter by a substring of its name or by backend
/// (`vulkan`, `metal`, `dx12`, `gl`).
pub const ADAPTER_ENV: &str = "MESHLESS_ADAPTER";

/// Environment variable that lowers the largest storage binding a pass may use below the
/// adapter's (bytes, or a number with a unit: `1MiB`), so that the neighbour lists split
/// into parts ([`super::parts`]) on any adapter.
pub const MAX_BINDING_ENV: &str = "MESHLESS_MAX_BINDING";

/// Invocations per workgroup of every 1D pass (see the shaders' `@workgroup_size`).
pub const WORKGROUP: u32 = 256;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found{}; adapters seen: [{}]. On Linux without a GPU install Mesa's \
         Vulkan CPU driver (Debian: mesa-vulkan-drivers) or run with --backend cpu",
        .requested.as_ref().map(|r| format!(" matching {ADAPTER_ENV}={r}")).unwrap_or_default(),
        .available.join("; ")
    )]
    NoAdapter {
        requested: Option<String>,
        available: Vec<String>,
    },
    #[error("adapter `{adapter}`: cannot create a device: {source}")]
    Device {
        adapter: String,
        source: wgpu::RequestDeviceError,
    },
    #[error(
        "adapter `{adapter}`: pass `{pass}` binds {count} storage buffers, above the adapter's \
         limit of {limit} per shader stage (max_storage_buffers_per_shader_stage); run with \
         --backend cpu, or on an adapter with a higher limit (Vulkan, Metal and DX12 \
         adapters allow 31 or more; `meshless info` lists each adapter's)"
    )]
    TooManyBuffers {
        adapter: String,
        pass: String,
        count: u32,
        limit: u32,
    },
    #[error(
        "{MAX_BINDING_ENV}={value}: give the largest storage binding as bytes or with a \
         unit: B, kB, MB, GB, TB (powers of 1000) or KiB, MiB, GiB, TiB (powers of 1024), \
         e.g. 1MiB"
    )]
    BindingEnv { value: String },
    #[error(
        "adapter `{adapter}`: pass `{pass}` binds `{binding}` of {bytes} bytes, above the \
         binding limit {limit} ({}); use fewer particles or a device with a larger limit \
         (`meshless info` lists each adapter's)",
        if *.forced { MAX_BINDING_ENV } else { "max_storage_buffer_binding_size" }
    )]
    BindingTooLarge {
        adapter: String,
        pass: String,
        binding: String,
        bytes: u64,
        limit: u64,
        forced: bool,
    },
    #[error("pass `{pass}` does not compile: {message}")]
    Shader { pass: String, message: String },
    #[error("pass `{pass}` uses the binding `{binding}`, which its engine does not provide")]
    Unbound { pass: String, binding: String },
    #[error(
        "adapter `{adapter}`: the scene needs a {what} of {needed} bytes, above the largest \
         storage binding, {limit} bytes (the adapter's max_storage_buffer_binding_size, or \
         {MAX_BINDING_ENV}); use fewer particles or a device with a larger limit"
    )]
    TooLarge {
        adapter: String,
        what: &'static str,
        needed: u64,
        limit: u64,
    },
}

/// A compiled entry point of a WGSL pass and the bindings it uses, by variable name.
#[derive(Clone)]
pub struct Pipeline {
    pub raw: wgpu::ComputePipeline,
    /// `label (entry)`, for messages and the pass report.
    pub pass: String,
    bindings: Vec<(u32, String)>,
    /// The bytes model of its pass file for this variant, if the file declares one.
    pub cost: Option<Cost>,
}

/// One adapter as `meshless info` shows it.
#[derive(Clone, Debug)]
pub struct AdapterSummary {
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (i, l) = (&self.info, &self.limits);
        writeln!(
            f,
            "{} ({:?}, {:?}, driver {} {})",
            i.name, i.backend, i.device_type, i.driver, i.driver_info
        )?;
        writeln!(
            f,
            "  max buffer {} B, max storage binding {} B, {} storage buffers per stage, \
             {} invocations per workgroup, {} workgroups per dimension",
            l.max_buffer_size,
            l.max_storage_buffer_binding_size,
            l.max_storage_buffers_per_shader_stage,
            l.max_compute_invocations_per_workgroup,
            l.max_compute_workgroups_per_dimension
        )?;
        write!(f, "  features: {:?}", self.features)
    }
}

fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

/// A WGSL `vec3<T>` in a uniform struct: 12 bytes aligned to 16, where `[T; 3]` would be
/// an array (stride 16 in the uniform address space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vec3<T>(pub [T; 3]);

impl<T> AsRef<[T; 3]> for Vec3<T> {
    fn as_ref(&self) -> &[T; 3] {
        &self.0
    }
}

encase::impl_vector!(3, Vec3<T>; using AsRef);

/// The bytes of a uniform struct laid out by WGSL's uniform rules (encase's `ShaderType`
/// checks alignment, strides and the offsets of its fields).
pub fn uniform_bytes<T: ShaderType + WriteInto>(value: &T) -> Vec<u8> {
    let mut buffer = encase::UniformBuffer::new(Vec::new());
    // A growable Vec takes any struct: writing into it has no failure to report.
    buffer
        .write(value)
        .expect("a Vec grows to hold the uniform struct");
    buffer.into_inner()
}

/// The unit test `$test` that the uniform struct `$ty` is laid out as naga lays out its
/// WGSL twin, the struct `$name` of the WGSL text `$wgsl` (exact: sizes in bytes).
macro_rules! wgsl_twin_test {
    ($test:ident: $ty:ty = $name:literal in $wgsl:expr) => {
        #[cfg(test)]
        #[test]
        fn $test() {
            use encase::ShaderType;
            let size = $crate::gpu::context::wgsl_struct_size($wgsl, $name);
            assert_eq!(<$ty>::min_size().get(), u64::from(size));
        }
    };
}
pub(crate) use wgsl_twin_test;

/// The size naga gives the struct `name` of a WGSL file (its declaration parsed alone),
/// for checking a uniform struct's `ShaderType` against the WGSL it mirrors.
#[cfg(test)]
pub(crate) fn wgsl_struct_size(wgsl: &str, name: &str) -> u32 {
    let start = wgsl
        .find(&format!("struct {name} {{"))
        .expect("the struct is declared");
    let end = start + wgsl[start..].find('}').expect("the struct is closed") + 1;
    let module = naga::front::wgsl::parse_str(&wgsl[start..end]).expect("it parses alone");
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(name))
        .expect("naga has the struct");
    ty.inner.size(module.to_ctx())
}

/// What an entry point of a WGSL source binds (naga reflection of the module wgpu
/// compiles): its bindings in group 0 by variable name, how many are storage buffers,
/// which storage buffers it reads and writes (loads and stores in the entry point and the
/// functions it calls; an atomic counts as both) and the bytes of an element of each
/// storage buffer's array.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reflection {
    pub bindings: Vec<(u32, String)>,
    pub storage_buffers: u32,
    pub reads: Vec<String>,
    pub writes: Vec<String>,
    pub element_bytes: Vec<(String, u32)>,
}

impl Reflection {
    /// How the entry point uses the storage binding `name`; None: not at all.
    pub fn binding_use(&self, name: &str) -> Option<BindingUse> {
        let has = |list: &[String]| list.iter().any(|n| n == name);
        let access = match (has(&self.reads), has(&self.writes)) {
            (true, true) => Access::ReadWrite,
            (true, false) => Access::Read,
            (false, true) => Access::Write,
            (false, false) => return None,
        };
        let (_, element_bytes) = self.element_bytes.iter().find(|(n, _)| n == name)?;
        Some(BindingUse {
            access,
            element_bytes: *element_bytes,
        })
    }
}

/// The module of a WGSL source and its validation info; Err: naga's message.
fn validated(source: &str) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .map_err(|e| e.emit_to_string(source))?;
    Ok((module, info))
}

/// The [`Reflection`] of entry point `entry`; Err: naga's message when the source does
/// not validate or has no such entry point.
pub fn reflect(source: &str, entry: &str) -> Result<Reflection, String> {
    let (module, info) = validated(source)?;
    reflect_module(&module, &info, entry)
}

fn reflect_module(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
) -> Result<Reflection, String> {
    use naga::valid::GlobalUse;
    let index = module
        .entry_points
        .iter()
        .position(|e| e.name == entry)
        .ok_or_else(|| format!("no entry point `{entry}`"))?;
    let uses = info.get_entry_point(index);
    let used = module
        .global_variables
        .iter()
        .filter(|(handle, var)| var.binding.is_some() && !uses[*handle].is_empty());
    let mut reflection = Reflection {
        bindings: Vec::new(),
        storage_buffers: 0,
        reads: Vec::new(),
        writes: Vec::new(),
        element_bytes: Vec::new(),
    };
    for (handle, var) in used {
        let binding = var.binding.as_ref().map_or(0, |b| b.binding);
        let name = var.name.clone().unwrap_or_default();
        reflection.bindings.push((binding, name.clone()));
        if matches!(var.space, naga::AddressSpace::Storage { .. }) {
            reflection.storage_buffers += 1;
            let element = match module.types[var.ty].inner {
                naga::TypeInner::Array { base, .. } => &module.types[base].inner,
                ref whole => whole,
            };
            let bytes = element.size(module.to_ctx());
            reflection.element_bytes.push((name.clone(), bytes));
            let used = uses[handle];
            if used.intersects(GlobalUse::READ | GlobalUse::ATOMIC) {
                reflection.reads.push(name.clone());
            }
            if used.intersects(GlobalUse::WRITE | GlobalUse::ATOMIC) {
                reflection.writes.push(name);
            }
        }
    }
    Ok(reflection)
}

/// The integer value of every scalar `const` of a module, by name.
fn integer_constants(module: &naga::Module) -> Vec<(String, i64)> {
    module
        .constants
        .iter()
        .filter_map(|(_, c)| {
            let value = match module.global_expressions[c.init] {
                naga::Expression::Literal(naga::Literal::U32(v)) => i64::from(v),
                naga::Expression::Literal(naga::Literal::I32(v)) => i64::from(v),
                naga::Expression::Literal(naga::Literal::AbstractInt(v)) => v,
                naga::Expression::Literal(naga::Literal::Bool(v)) => i64::from(v),
                _ => return None,
            };
            Some((c.name.clone()?, value))
        })
        .collect()
}

/// The bytes model of entry point `entry` of a composed pass ([`pass_model`]) in the
/// variant its constants select. Err: the model is malformed, or names a constant the
/// variant lacks or a binding (or a direction of one) the entry point does not use.
pub fn pass_cost(source: &str, entry: &str) -> Result<Option<Cost>, String> {
    let (module, info) = validated(source)?;
    let reflection = reflect_module(&module, &info, entry)?;
    cost_in(&module, &reflection, source, entry)
}

/// [`pass_cost`] of the parsed `module` of `source`: each binding's access and element
/// type from the entry point's `reflection`.
fn cost_in(
    module: &naga::Module,
    reflection: &Reflection,
    source: &str,
    entry: &str,
) -> Result<Option<Cost>, String> {
    let Some(model) = pass_model(source, entry)? else {
        return Ok(None);
    };
    let constants = integer_constants(module);
    model
        .cost(
            |name| constants.iter().find(|(n, _)| n == name).map(|c| c.1),
            |name| reflection.binding_use(name),
        )
        .map(Some)
}

/// Every adapter wgpu reaches, best first ([`rank`]).
fn ranked() -> Vec<wgpu::Adapter> {
    let mut list: Vec<wgpu::Adapter> =
        pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()));
    list.sort_by_key(rank);
    list
}

/// Every adapter wgpu reaches, best first.
pub fn adapters() -> Vec<AdapterSummary> {
    ranked()
        .iter()
        .map(|a| AdapterSummary {
            info: a.get_info(),
            limits: a.limits(),
            features: a.features(),
        })
        .collect()
}

/// What `--backend auto` runs on: the best adapter, unless it emulates a GPU on the CPU
/// (Mesa's lavapipe, SwiftShader: slower than the CPU backend) and `MESHLESS_ADAPTER`
/// does not name it. Err: why the CPU backend runs instead.
/// The binding limit [`MAX_BINDING_ENV`] forces, if set; Err where its value is not a
/// size.
pub fn binding_env() -> Result<Option<u64>, GpuError> {
    match std::env::var(MAX_BINDING_ENV) {
        Err(_) => Ok(None),
        Ok(value) => match crate::case::parse_bytes(&value) {
            Some(bytes) => Ok(Some(bytes as u64)),
            None => Err(GpuError::BindingEnv { value }),
        },
    }
}

pub fn auto_adapter() -> Result<String, String> {
    let requested = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
    let list = adapters();
    let chosen = list
        .iter()
        .find(|a| requested.as_deref().is_none_or(|r| matches(&a.info, r)));
    match (chosen, requested) {
        (None, _) => Err("no GPU adapter found".into()),
        (Some(a), None) if a.info.device_type == wgpu::DeviceType::Cpu => Err(format!(
            "the only adapter, {}, emulates a GPU on the CPU (--backend gpu runs on it)",
            describe(&a.info)
        )),
        (Some(a), _) => Ok(describe(&a.info)),
    }
}

/// Preference order: discrete, integrated, virtual, CPU; Vulkan/Metal/DX12 before GL.
fn rank(a: &wgpu::Adapter) -> (u8, u8) {
    let info = a.get_info();
    let device = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = u8::from(info.backend == wgpu::Backend::Gl);
    (device, backend)
}

fn matches(info: &wgpu::AdapterInfo, wanted: &str) -> bool {
    let wanted = wanted.to_lowercase();
    info.name.to_lowercase().contains(&wanted)
        || format!("{:?}", info.backend).to_lowercase() == wanted
}

/// A device and its queue on the chosen adapter, with the adapter's own limits.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// The pass report's recording, while profiling ([`Gpu::profile`]).
    pub(crate) profiler: Mutex<Option<Profiler>>,
    /// The copy bandwidth, once measured [B/s].
    pub(crate) copy: Mutex<Option<f64>>,
    /// The bytes of the buffers made so far, by label ([`Gpu::allocated`]).
    ledger: Mutex<BTreeMap<String, u64>>,
    /// The largest storage binding a pass may use ([`Gpu::binding_limit`]) and whether
    /// it is below the adapter's.
    binding: (u64, bool),
}

impl Gpu {
    /// Opens the best adapter, or the one named by `MESHLESS_ADAPTER`.
    pub fn new() -> Result<Self, GpuError> {
        Self::matching(std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty()))
    }

    /// Opens the best adapter whose name contains `requested` or whose backend it names
    /// (`vulkan`, `metal`, `dx12`, `gl`), or the best of all for None.
    pub fn matching(requested: Option<String>) -> Result<Self, GpuError> {
        let list = ranked();
        let available: Vec<String> = list.iter().map(|a| describe(&a.get_info())).collect();
        let adapter = list
            .into_iter()
            .find(|a| {
                requested
                    .as_deref()
                    .is_none_or(|r| matches(&a.get_info(), r))
            })
            .ok_or(GpuError::NoAdapter {
                requested,
                available,
            })?;
        Self::open(adapter)
    }

    /// Opens every adapter wgpu reaches, best first (Mesa's lavapipe through Vulkan and
    /// llvmpipe through GL are two); each Err says why that one has no device.
    pub fn every() -> Vec<Result<Self, GpuError>> {
        ranked().into_iter().map(Self::open).collect()
    }

    /// A device on `adapter` with the adapter's own limits, and timestamp queries inside
    /// compute passes where it has them (for the pass report).
    fn open(adapter: wgpu::Adapter) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let limits = adapter.limits();
        let timestamps =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("meshless"),
            required_features: adapter.features() & timestamps,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|source| GpuError::Device {
            adapter: describe(&info),
            source,
        })?;
        let adapter_limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let gpu = Self {
            device,
            queue,
            info,
            limits,
            profiler: Mutex::new(None),
            copy: Mutex::new(None),
            ledger: Mutex::new(BTreeMap::new()),
            binding: (adapter_limit, false),
        };
        Ok(match binding_env()? {
            Some(bytes) => gpu.with_binding_limit(bytes),
            None => gpu,
        })
    }

    /// This device with its largest storage binding lowered to `bytes` (a multiple of
    /// 4), where that is below the adapter's: what [`MAX_BINDING_ENV`] sets.
    pub fn with_binding_limit(mut self, bytes: u64) -> Self {
        let bytes = (bytes / 4 * 4).max(4);
        if bytes < self.binding.0 {
            self.binding = (bytes, true);
        }
        self
    }

    /// The largest storage binding a pass may use [bytes]: the adapter's
    /// `max_storage_buffer_binding_size` (and buffer size), or [`MAX_BINDING_ENV`]'s.
    pub fn binding_limit(&self) -> u64 {
        self.binding.0
    }

    pub fn name(&self) -> String {
        describe(&self.info)
    }

    /// Fails with a clear error when a buffer of `bytes` exceeds the device's limits.
    pub fn check_size(&self, what: &'static str, bytes: u64) -> Result<(), GpuError> {
        let limit = self.binding_limit();
        if bytes > limit {
            return Err(GpuError::TooLarge {
                adapter: self.name(),
                what,
                needed: bytes,
                limit,
            });
        }
        Ok(())
    }

    /// The bytes of the buffers made on this device so far, but for the read-back and
    /// profiling buffers, which live for one copy: what a run's set-up allocated, read
    /// after it. A buffer made again (a list that grew) counts each time.
    pub fn allocated(&self) -> u64 {
        self.allocations().values().sum()
    }

    /// [`Self::allocated`] by buffer label.
    pub fn allocations(&self) -> BTreeMap<String, u64> {
        self.ledger.lock().expect("the ledger").clone()
    }

    /// Books `buffer`, made under `label`, in the ledger.
    fn booked(&self, label: &str, buffer: wgpu::Buffer) -> wgpu::Buffer {
        let mut ledger = self.ledger.lock().expect("the ledger");
        *ledger.entry(label.to_owned()).or_default() += buffer.size();
        buffer
    }

    /// A storage buffer holding `data` (at least 4 bytes, so empty fields still bind).
    pub fn storage<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let contents: Cow<[u8]> = if bytes.is_empty() {
            Cow::Owned(vec![0; 4])
        } else {
            Cow::Borrowed(bytes)
        };
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            });
        self.booked(label, buffer)
    }

    /// A zero-filled storage buffer of `bytes` (at least 4).
    pub fn zeroed(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.booked(label, self.scratch(label, bytes))
    }

    /// [`Self::zeroed`] without booking it: a buffer that lives for one measurement.
    pub(crate) fn scratch(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A zero-filled buffer of `bytes` that a pass writes and an indirect dispatch reads
    /// its workgroup counts from.
    pub fn indirect(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            mapped_at_creation: false,
        });
        self.booked(label, buffer)
    }

    /// A uniform buffer holding `value`, laid out by WGSL's uniform rules.
    pub fn uniform<T: ShaderType + WriteInto>(&self, label: &str, value: &T) -> wgpu::Buffer {
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &uniform_bytes(value),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        self.booked(label, buffer)
    }

    /// Writes `value` over the uniform buffer `buffer` (made by [`Gpu::uniform`]).
    pub fn write_uniform<T: ShaderType + WriteInto>(&self, buffer: &wgpu::Buffer, value: &T) {
        self.queue.write_buffer(buffer, 0, &uniform_bytes(value));
    }

    /// The compute pipeline of entry point `entry` of a WGSL pass, after checking that it
    /// binds no more storage buffers than the adapter allows (layout from the shader).
    pub fn pipeline(&self, label: &str, source: &str, entry: &str) -> Result<Pipeline, GpuError> {
        let pass = format!("{label} ({entry})");
        let shader = |message| GpuError::Shader {
            pass: pass.clone(),
            message,
        };
        let (module, info) = validated(source).map_err(shader)?;
        let reflection = reflect_module(&module, &info, entry).map_err(shader)?;
        let cost = cost_in(&module, &reflection, source, entry).map_err(shader)?;
        let limit = self.limits.max_storage_buffers_per_shader_stage;
        if reflection.storage_buffers > limit {
            return Err(GpuError::TooManyBuffers {
                adapter: self.name(),
                pass,
                count: reflection.storage_buffers,
                limit,
            });
        }
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let raw = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        Ok(Pipeline {
            raw,
            pass,
            bindings: reflection.bindings,
            cost,
        })
    }

    /// Bind group 0 of `pipeline`, each binding its entry point uses taking the buffer of
    /// the same variable name in `resources` (names it does not use are ignored, so one
    /// table serves every entry point of a file). Err names the pass and the binding
    /// that `resources` lacks, or whose buffer exceeds the binding limit.
    pub fn bind(
        &self,
        pipeline: &Pipeline,
        resources: &[(&str, &wgpu::Buffer)],
    ) -> Result<wgpu::BindGroup, GpuError> {
        let entries = pipeline
            .bindings
            .iter()
            .map(|(binding, name)| {
                let buffer = resources
                    .iter()
                    .rev()
                    .find(|(n, _)| n == name)
                    .ok_or_else(|| GpuError::Unbound {
                        pass: pipeline.pass.clone(),
                        binding: name.clone(),
                    })?
                    .1;
                if buffer.size() > self.binding.0 {
                    return Err(GpuError::BindingTooLarge {
                        adapter: self.name(),
                        pass: pipeline.pass.clone(),
                        binding: name.clone(),
                        bytes: buffer.size(),
                        limit: self.binding.0,
                        forced: self.binding.1,
                    });
                }
                Ok(wgpu::BindGroupEntry {
                    binding: *binding,
                    resource: buffer.as_entire_binding(),
                })
            })
            .collect::<Result<Vec<_>, GpuError>>()?;
        Ok(self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&pipeline.pass),
            layout: &pipeline.raw.get_bind_group_layout(0),
            entries: &entries,
        }))
    }

    /// Workgroup counts covering `n` invocations of `WORKGROUP`: 2D past 65,535 groups.
    /// Shaders flatten with `index(gid, nwg)` of `shaders/common/dispatch.wgsl`.
    pub fn groups(&self, n: u32) -> (u32, u32) {
        let groups = n.div_ceil(WORKGROUP).max(1);
        let max = self.limits.max_compute_workgroups_per_dimension;
        if groups <= max {
            (groups, 1)
        } else {
            (max, groups.div_ceil(max))
        }
    }

    /// Records one dispatch of `pipeline` over `n` invocations in `pass`.
    pub fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        n: u32,
    ) {
        self.dispatch_part(pass, pipeline, bind, n, 1.0);
    }

    /// Records one dispatch of `pipeline` a part of the neighbour lists, each over the
    /// part's rows with its bind group of `binds`: `parts` gives each part's rows and
    /// share of the pairs (`gpu::parts`).
    pub fn dispatch_parts(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        binds: &[wgpu::BindGroup],
        parts: impl ExactSizeIterator<Item = (u32, f64)>,
    ) {
        assert_eq!(binds.len(), parts.len(), "a bind group a part");
        for ((rows, share), bind) in parts.zip(binds) {
            self.dispatch_part(pass, pipeline, bind, rows, share);
        }
    }

    /// Records one dispatch of `pipeline` over the `rows` particles of a part of the
    /// neighbour lists holding `share` of their pairs (`gpu::parts`).
    pub fn dispatch_part(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        rows: u32,
        share: f64,
    ) {
        let work = (u64::from(rows), share);
        self.dispatch_work(pass, pipeline, bind, self.groups(rows), work);
    }

    /// Records one dispatch of `pipeline` over `groups` workgroups in `pass`, `items`
    /// items of its bytes model (profiled like every dispatch).
    pub fn dispatch_groups(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        groups: (u32, u32),
        items: u64,
    ) {
        self.dispatch_work(pass, pipeline, bind, groups, (items, 1.0));
    }

    /// One direct dispatch over `groups`, booked as `work` (items, share of the pairs).
    fn dispatch_work(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        (x, y): (u32, u32),
        work: (u64, f64),
    ) {
        self.record(pass, pipeline, bind, work, false, |pass| {
            pass.dispatch_workgroups(x, y, 1);
        });
    }

    /// Records one dispatch of `pipeline` with the workgroup counts at `offset` bytes of
    /// `args`, `items` items of its bytes model and `share` of the lists' pairs (1 but
    /// for a part of them) when it runs.
    pub fn dispatch_indirect(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        (args, offset): (&wgpu::Buffer, u64),
        work: (u64, f64),
    ) {
        self.record(pass, pipeline, bind, work, true, |pass| {
            pass.dispatch_workgroups_indirect(args, offset);
        });
    }

    fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &Pipeline,
        bind: &wgpu::BindGroup,
        work: (u64, f64),
        indirect: bool,
        encode: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) {
        pass.set_pipeline(&pipeline.raw);
        pass.set_bind_group(0, bind, &[]);
        match self.profiler.lock().expect("profiler lock").as_mut() {
            Some(profiler) => {
                profiler.dispatch(&self.device, pass, pipeline, work, indirect, encode);
            }
            None => encode(pass),
        }
    }

    /// Blocks until every submitted command buffer has finished (and, when profiling,
    /// reads the timestamps written so far back).
    pub fn wait(&self) {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("waiting for the GPU queue");
        self.resolve_profile();
    }

    /// Copies a buffer back to the host (waits for the queue).
    pub fn read<T: Pod>(&self, buffer: &wgpu::Buffer) -> Vec<T> {
        self.read_range(buffer, 0, buffer.size())
    }

    /// Reads `size` bytes of a buffer from byte `offset` (both multiples of 4).
    pub fn read_range<T: Pod>(&self, buffer: &wgpu::Buffer, offset: u64, size: u64) -> Vec<T> {
        if size == 0 {
            return Vec::new();
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let slice = staging.slice(..);
        slice.map_async(wgpu::MapMode::Read, |r| {
            r.expect("mapping a readback buffer")
        });
        self.wait();
        let view = slice
            .get_mapped_range()
            .expect("mapped range of a readback buffer");
        let out = bytemuck::cast_slice(&view).to_vec();
        drop(view);
        staging.unmap();
        out
    }
}
