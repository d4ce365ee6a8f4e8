#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| dentsim_fuzz::tissue_toml(data));
