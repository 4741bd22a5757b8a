//! Development aid: 2D FFT timing at 871×617.
use laydown::stages::image::fft2::Fft2;
use ndarray::Array2;
use num_complex::Complex64;
fn main() {
    let t = std::time::Instant::now();
    let plan = Fft2::new(617, 871);
    println!("plan {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let mut a = Array2::from_shape_fn((617, 871), |(i, j)| Complex64::new((i * j % 7) as f64, 0.0));
    for _ in 0..5 {
        let t = std::time::Instant::now();
        plan.forward(&mut a);
        println!("fwd {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    }
}
