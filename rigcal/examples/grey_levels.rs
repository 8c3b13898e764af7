//! Development probe: writes the detector's grey image of a photo as PNG.
//! `cargo run -p matscan-rigcal --example grey_levels -- PHOTO.exr OUT.png`

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(input), Some(output)) = (args.get(1), args.get(2)) else {
        return Err("usage: grey_levels PHOTO.exr OUT.png".into());
    };
    let photo = matscan_rigcal::camera::read_shot(std::path::Path::new(input))?;
    matscan_rigcal::detect::grey_levels(&photo).save(output)?;
    Ok(())
}
