//! A rate evaluation of the mixed methods allocates nothing once its buffers exist. A
//! global allocator counts the allocations of the thread that evaluates the rates, while
//! it evaluates them (the test harness's own threads allocate when they will).

use meshless::core::integrate::OdeSystem;
use meshless::core::tensor::D2;
use meshless::methods::Method;
use meshless::methods::mixed::MixedSph;
use meshless::run::build_method;
use meshless::scene::Scene;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts the allocations and reallocations of the threads that set `COUNTED`, then hands
/// every request to the system allocator.
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTED.try_with(Cell::get).unwrap_or(false) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// Upwind-SPH with mirror ghosts and reconstruction (the swinging plate), with the
/// projection and without ghosts (the spinning plate), JST-SPH, and the {p, F} system with
/// the bond-based F: after two evaluations, ten more allocate nothing. On a pool of one
/// thread, which does all of an evaluation's work and is the thread counted.
#[test]
fn a_mixed_rate_evaluation_does_not_allocate() {
    let path = |name: &str| format!("{}/cases/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (name, set) in [
        ("swinging-plate", vec!["spacing=0.05"]),
        ("spinning-plate", vec!["spacing=0.1"]),
        (
            "swinging-plate",
            vec!["spacing=0.05", "method.name=jst-sph"],
        ),
        (
            "spinning-plate",
            vec![
                "spacing=0.1",
                "method.variables=\"p-F\"",
                "method.deformation_gradient=\"bond-based\"",
            ],
        ),
    ] {
        let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
        let case = Scene::load(std::path::Path::new(&path(name)), &set).unwrap();
        let mut system: MixedSph<D2> = build_method(&case).unwrap();
        let y = system.initial_state();
        let mut rates = y.clone();
        let counted = pool.install(|| {
            for _ in 0..2 {
                system.rates(0.0, &y, &mut rates).unwrap();
            }
            let before = ALLOCATIONS.load(Ordering::Relaxed);
            COUNTED.set(true);
            for _ in 0..10 {
                system.rates(0.0, &y, &mut rates).unwrap();
            }
            COUNTED.set(false);
            ALLOCATIONS.load(Ordering::Relaxed) - before
        });
        assert_eq!(
            counted, 0,
            "{name} {set:?}: allocations in ten rate evaluations"
        );
    }
}
