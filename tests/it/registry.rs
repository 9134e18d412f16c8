//! The method registry: one name per method everywhere, every method's keys, and what
//! `--set method.name=X` does to the keys of the previous method.

use crate::common::{case_file, load, shipped};
use meshless::case::CaseError;
use meshless::methods::mixed::{Conserved, DeformationGradient, Jst, Momentum};
use meshless::methods::{COMMON_KEYS, MethodSpec, REGISTRY, entry};
use meshless::scene::Scene;

/// The error of a shipped case with overrides; panics if it loads.
fn load_error(name: &str, overrides: &[&str]) -> (CaseError, String) {
    let path = case_file(name);
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    match Scene::load(&path, &overrides) {
        Ok(_) => panic!("{name} with {overrides:?} was accepted"),
        Err(e) => {
            let shown = e.to_string();
            (e, shown)
        }
    }
}

#[test]
fn a_change_of_method_keeps_the_keys_both_read_and_drops_the_others() {
    // The bending column is JST-SPH {p, F} with the symmetrised momentum, the bond-based F,
    // no projection and its own ε⁽⁴⁾. Upwind-SPH reads all of these but `jst`.
    let jst = shipped("bending-column");
    let MethodSpec::JstSph(before) = &jst.spec else {
        panic!("the bending column is a jst-sph case")
    };
    assert_eq!(before.jst.eps4, 0.015625);
    assert!(jst.notes.is_empty(), "{:?}", jst.notes);

    let upwind = load("bending-column", &["method.name=upwind-sph"]);
    let MethodSpec::UpwindSph(after) = &upwind.spec else {
        panic!("method.name=upwind-sph gave {:?}", upwind.spec)
    };
    assert_eq!(
        after.mixed, before.mixed,
        "the keys both methods read are kept"
    );
    assert_eq!(after.mixed.variables, Conserved::PF);
    assert_eq!(after.mixed.momentum, Momentum::Symmetrised);
    assert_eq!(
        after.mixed.deformation_gradient,
        DeformationGradient::BondBased
    );
    assert_eq!(after.mixed.projection, Some(false));
    assert!(
        after.reconstruction,
        "upwind-sph's own key takes its default"
    );
    assert_eq!(
        (
            upwind.method.kernel,
            upwind.method.h_over_dx,
            upwind.method.cfl
        ),
        (jst.method.kernel, jst.method.h_over_dx, jst.method.cfl),
        "the common keys are kept"
    );
    assert_eq!(upwind.notes.len(), 1, "{:?}", upwind.notes);
    assert!(
        upwind.notes[0].contains("`method.jst`") && upwind.notes[0].contains("upwind-sph"),
        "{}",
        upwind.notes[0]
    );

    // Back to jst-sph: ε⁽⁴⁾ was dropped, so it takes the default of 1/8.
    let back = load(
        "bending-column",
        &["method.name=upwind-sph", "method.name=jst-sph"],
    );
    let MethodSpec::JstSph(again) = &back.spec else {
        panic!("method.name=jst-sph gave {:?}", back.spec)
    };
    assert_eq!(again.jst, Jst::default());
}

#[test]
fn a_change_of_method_drops_tlsph_viscosity_and_keeps_an_explicit_key() {
    // The tensile strip is TLSPH with artificial viscosity; the mixed methods need a
    // state model and a first-order correction, which the other overrides give.
    let mixed = [
        "method.name=upwind-sph",
        "material.model=neo-hookean",
        "method.correction=cgck",
    ];
    let case = load("tensile-strip", &mixed);
    assert_eq!(case.method.name, "upwind-sph");
    assert!(
        case.notes
            .iter()
            .any(|n| n.contains("`method.artificial_viscosity`")),
        "{:?}",
        case.notes
    );
    // A key of another method set in the same command is kept, so it is reported.
    let with_jst: Vec<&str> = mixed
        .iter()
        .copied()
        .chain(["method.jst={ eps4 = 0.1 }"])
        .collect();
    let (e, shown) = load_error("tensile-strip", &with_jst);
    assert!(matches!(e, CaseError::Invalid { .. }), "{shown}");
    assert!(
        shown.contains("key `method.jst`") && shown.contains("`jst-sph`"),
        "{shown}"
    );
    // Setting the name a case already has changes nothing.
    let same = load("tensile-strip", &["method.name=tlsph"]);
    assert!(same.notes.is_empty(), "{:?}", same.notes);
    assert_eq!(same.method, shipped("tensile-strip").method);
}

#[test]
fn a_method_with_its_own_consistent_functions_refuses_a_correction_by_name() {
    // `kbm`, `efg`, `tl-weak-form` and `dual-support-sph` build their own consistent
    // functions, so `method.correction` would be read by none of their code: it is
    // refused, naming the method; switching to one of them from a case that gives it
    // (the SPH rod, `correction = "none"`) drops it with a note.
    for name in ["kbm", "efg", "tl-weak-form", "dual-support-sph"] {
        assert!(!entry(name).unwrap().reads("correction"), "{name}");
    }
    assert!(entry("tlsph").unwrap().reads("correction"));
    let (_, shown) = load_error("rod-gaussian-kbm", &["method.correction=shepard"]);
    assert!(
        shown.contains(
            "`kbm` builds its own consistent functions and reads no \
             `method.correction`"
        ),
        "{shown}"
    );
    let switched = load("rod-gaussian", &["method.name=kbm"]);
    assert!(
        switched
            .notes
            .iter()
            .any(|n| n.contains("`method.correction`")),
        "{:?}",
        switched.notes
    );
}

#[test]
fn every_method_has_one_name_in_case_files_listings_and_summaries() {
    // Every registered name parses as a case's method, and the case reports it back
    // under the same name (the summary's `method` is `case.method.name`).
    for e in REGISTRY {
        let mut set = vec![format!("method.name={}", e.name)];
        if e.name != "tlsph" && e.keys.contains(&"force") {
            // The strip's `force = "reveles"` is TLSPH's value: the method's own default.
            set.push("method.force=".into());
        }
        match e.name {
            // The strip's hypoelastic model and Randles–Libersky correction suit these
            // (`ul-weak-form` reads no correction).
            "tlsph" | "gray-monaghan-sph" | "godunov-sph" | "ul-weak-form" => {}
            // No kernel, or functions of their own: no correction.
            _ if !e.corrected => set.push("material.model=neo-hookean".into()),
            _ => set.extend([
                "material.model=neo-hookean".into(),
                "method.correction=cgck".into(),
            ]),
        }
        let set: Vec<&str> = set.iter().map(String::as_str).collect();
        let case = load("tensile-strip", &set);
        assert_eq!(case.method.name, e.name);
        assert_eq!(case.spec.entry().name, e.name);
        assert!(entry(e.name).is_some_and(|x| std::ptr::eq(x, e)));
        assert!(!e.description.is_empty());
        for key in e.keys {
            assert!(!COMMON_KEYS.contains(key), "{}: {key}", e.name);
        }
    }
    // An unknown name lists the registered ones.
    let (e, shown) = load_error("tensile-strip", &["method.name=tl-sph"]);
    assert!(matches!(e, CaseError::Parse { .. }), "{shown}");
    for m in REGISTRY {
        assert!(shown.contains(&format!("`{}`", m.name)), "{shown}");
    }
}

/// The benches' table of cases, compiled here so that a method without one fails a test
/// rather than the bench run (its `time_step` serves the benches only).
#[path = "../../benches/common/mod.rs"]
#[allow(dead_code)]
mod bench_cases;

#[test]
fn every_method_has_a_bench_case_that_loads() {
    // `cargo bench` steps every method of the registry on its case of
    // `benches/common/mod.rs`, resized to about 2,000 particles; a method added without
    // one would panic there.
    for entry in REGISTRY {
        let (case, _) = bench_cases::method_case(entry.name);
        assert_eq!(case.method.name, entry.name);
    }
}

#[test]
fn every_method_has_a_row_and_a_page_in_the_methods_index() {
    // docs/methods/README.md: one table row per registered method, `| \`name\` |
    // [page](page) |`, whose page exists; a method added without one fails.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/methods");
    let index = std::fs::read_to_string(dir.join("README.md")).unwrap();
    for entry in REGISTRY {
        let row = index
            .lines()
            .find(|l| l.starts_with(&format!("| `{}` | [", entry.name)))
            .unwrap_or_else(|| panic!("{}: no row in docs/methods/README.md", entry.name));
        // The page, without the section anchor a row may link to.
        let page = row
            .split("](")
            .nth(1)
            .and_then(|s| s.split([')', '#']).next())
            .unwrap();
        assert!(
            dir.join(page).is_file(),
            "{}: {page} does not exist",
            entry.name
        );
    }
}
