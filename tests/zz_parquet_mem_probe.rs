#![allow(unsafe_code)]
#![allow(clippy::unwrap_used)]
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering::Relaxed};
struct Counting;
static LIVE: AtomicIsize = AtomicIsize::new(0);
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size() as isize, Relaxed);
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        LIVE.fetch_add(n as isize - l.size() as isize, Relaxed);
        unsafe { System.realloc(p, l, n) }
    }
}
#[global_allocator]
static A: Counting = Counting;
use simserpent::record::{ColumnKind, ParquetTable, TableSink};
fn rss_kb() -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap();
    let l = s.lines().find(|l| l.starts_with("VmRSS")).unwrap();
    l.split_whitespace().nth(1).unwrap().parse().unwrap()
}
#[test]
#[ignore]
fn probe() {
    let r: usize = std::env::var("R").map(|v| v.parse().unwrap()).unwrap_or(1000);
    let cols = 656;
    let header: Vec<String> = (0..cols).map(|i| format!("c{i}")).collect();
    let kinds = vec![ColumnKind::Float; cols];
    let dir = tempfile::tempdir().unwrap();
    let mut t = ParquetTable::create(&dir.path().join("x.parquet"), &header, &kinds, r).unwrap();
    let mut x = 0.1f64;
    for row in 0..60000u64 {
        for _ in 0..cols {
            x = (x * 1.000001 + 0.37).fract();
            t.num(x).unwrap();
        }
        t.end_row().unwrap();
        if row % 6000 == 0 {
            eprintln!("R={r} row {row} rss {} kB live {} kB", rss_kb(), LIVE.load(Relaxed) / 1024);
        }
    }
    eprintln!("R={r} end rss {} kB", rss_kb());
    t.finish().unwrap();
}
