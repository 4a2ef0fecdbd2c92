//! A DARE solve with a reused workspace allocates nothing: cold and warm,
//! dense and decoupled (a counting global allocator, as in the main crate's
//! tests/common/alloc.rs).

use nalgebra::DMatrix;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use tandem_solvers::riccati::{DareProblem, DareSettings, DareWorkspace, double_integrator};

struct CountingAllocator;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: defers every operation to the system allocator; the counter is a
// const-initialised thread-local, which does not allocate.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

#[test]
fn repeated_solves_allocate_nothing() {
    let (a, b) = double_integrator(7, 0.01);
    let q = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(14, |k, _| if k < 7 { 100.0 } else { 1.0 }));
    let r = DMatrix::<f64>::identity(7, 7) * 0.1;
    // A coupled system of the same size: the dense path.
    let coupled = DMatrix::from_fn(14, 14, |i, j| if i == j { 0.9 } else { 0.01 * ((i + 2 * j) % 5) as f64 });
    for (a, decouple) in [(&a, true), (&a, false), (&coupled, true)] {
        let settings = DareSettings { decouple, ..DareSettings::default() };
        let problem = DareProblem::new(a, &b, &q, &r);
        let mut ws = DareWorkspace::new(14, 7);
        ws.solve(&problem, &settings).expect("solvable");
        let (p, nearby) = (ws.p().clone(), ws.p() * 1.01);
        ws.solve_warm(&problem, &settings, &p).expect("solvable");
        let before = allocations();
        ws.solve(&problem, &settings).expect("solvable");
        ws.solve_warm(&problem, &settings, &p).expect("solvable");
        ws.solve_warm(&problem, &settings, &nearby).expect("solvable");
        assert_eq!(allocations(), before, "decouple = {decouple}");
    }
}
