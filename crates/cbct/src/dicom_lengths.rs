//! Element lengths checked against the file before dicom-rs reads it: its parser allocates an
//! element at the length the header states, and a garbled header stating gigabytes aborts the
//! process (found by fuzzing). A walk over the element headers (preamble, the meta group in
//! explicit VR little endian, then the data set in the transfer syntax it names) refuses any
//! length past the end of the file. Sequences and items are walked into, so nested elements are
//! checked too; encapsulated pixel data's fragments are skipped over.
use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry, VirtualVr};
use dicom_core::{Tag, VR};
use dicom_dictionary_std::StandardDataDictionary;

const IMPLICIT_LE: &str = "1.2.840.10008.1.2";
const EXPLICIT_BE: &str = "1.2.840.10008.1.2.2";
const DEFLATED: &str = "1.2.840.10008.1.2.1.99";
const UNDEFINED: u32 = 0xFFFF_FFFF;

/// Ok when every stated element length fits in the bytes that follow it; else which element
/// claims how much, and where.
pub fn check(bytes: &[u8]) -> Result<(), String> {
    let start = if bytes.len() >= 132 && &bytes[128..132] == b"DICM" { 132 } else { 0 };
    let mut w = Walk { b: bytes, pos: start, explicit: true, big: false, fragments: Vec::new() };
    // The meta group: explicit VR little endian, group 0002.
    let mut syntax = String::new();
    while w.pos + 4 <= bytes.len() && w.u16(w.pos) == 0x0002 {
        let (tag, at, len) = w.element()?;
        if tag == Tag(0x0002, 0x0010) {
            syntax = String::from_utf8_lossy(&bytes[at..at + len as usize]).trim_matches(|c: char| c == '\0' || c == ' ').to_string();
        }
        w.pos = at + len as usize;
    }
    match syntax.as_str() {
        // Deflated data sets are compressed: nothing to walk before inflating.
        DEFLATED => return Ok(()),
        IMPLICIT_LE => w.explicit = false,
        EXPLICIT_BE => w.big = true,
        // No meta group (a bare data set): dicom-rs reads those as implicit VR little endian.
        "" if start == 0 => w.explicit = false,
        _ => {}
    }
    while w.pos < bytes.len() {
        let (tag, at, len) = w.element()?;
        w.pos = if len == UNDEFINED || w.walk_into(tag) { at } else { at + len as usize };
    }
    Ok(())
}

struct Walk<'a> {
    b: &'a [u8],
    pos: usize,
    explicit: bool,
    big: bool,
    /// Per open undefined-length element: whether its items are pixel-data fragments (raw bytes).
    fragments: Vec<bool>,
}

impl Walk<'_> {
    fn u16(&self, at: usize) -> u16 {
        let v = [self.b[at], self.b[at + 1]];
        if self.big { u16::from_be_bytes(v) } else { u16::from_le_bytes(v) }
    }

    fn u32(&self, at: usize) -> u32 {
        let v = [self.b[at], self.b[at + 1], self.b[at + 2], self.b[at + 3]];
        if self.big { u32::from_be_bytes(v) } else { u32::from_le_bytes(v) }
    }

    /// The element header at `pos`: its tag, where its value starts and its stated length
    /// (checked to fit unless undefined). Items and delimiters have no VR.
    fn element(&mut self) -> Result<(Tag, usize, u32), String> {
        let (b, pos) = (self.b, self.pos);
        let short = || format!("element header at byte {pos} is cut short by the end of the file");
        if pos + 8 > b.len() {
            return Err(short());
        }
        let tag = Tag(self.u16(pos), self.u16(pos + 2));
        let (at, len) = if tag.0 == 0xFFFE || !self.explicit {
            (pos + 8, self.u32(pos + 4))
        } else {
            let vr = &b[pos + 4..pos + 6];
            // A 2-byte length only for the VRs that have one; any other, unknown ones included,
            // is read as UN is (dicom-rs does: a garbled VR took a 4-byte length of gigabytes).
            let two_byte_length = matches!(
                vr,
                b"AE" | b"AS" | b"AT" | b"CS" | b"DA" | b"DS" | b"DT" | b"FL" | b"FD" | b"IS" | b"LO" | b"LT" | b"PN" | b"SH" | b"SL" | b"SS" | b"ST" | b"TM" | b"UI" | b"UL" | b"US"
            );
            if !two_byte_length {
                if pos + 12 > b.len() {
                    return Err(short());
                }
                (pos + 12, self.u32(pos + 8))
            } else {
                (pos + 8, u32::from(self.u16(pos + 6)))
            }
        };
        if len != UNDEFINED && len as usize > b.len() - at {
            return Err(format!(
                "element ({:04X},{:04X}) at byte {pos} states a length of {len} bytes, but only {} follow it",
                tag.0,
                tag.1,
                b.len() - at
            ));
        }
        match (tag, len) {
            // An undefined length opens a sequence, or pixel data whose items are fragments.
            (Tag(0xFFFE, 0xE0DD), _) => {
                self.fragments.pop();
            }
            (Tag(0xFFFE, _), _) => {}
            (_, UNDEFINED) => self.fragments.push(tag == Tag(0x7FE0, 0x0010)),
            _ => {}
        }
        Ok((tag, at, len))
    }

    /// Whether a defined-length element's value is itself elements to check: a sequence, or an
    /// item of one (not a pixel-data fragment).
    fn walk_into(&self, tag: Tag) -> bool {
        if tag == Tag(0xFFFE, 0xE000) {
            return !self.fragments.last().copied().unwrap_or(false);
        }
        if tag.0 == 0xFFFE {
            return true;
        }
        if self.explicit {
            let pos = self.pos;
            return &self.b[pos + 4..pos + 6] == b"SQ";
        }
        StandardDataDictionary.by_tag(tag).is_some_and(|e| matches!(e.vr(), VirtualVr::Exact(VR::SQ)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn explicit_le(tag: (u16, u16), vr: &[u8; 2], value: &[u8], long: bool, len: Option<u32>) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(tag.0.to_le_bytes());
        out.extend(tag.1.to_le_bytes());
        out.extend(vr);
        let len = len.unwrap_or(value.len() as u32);
        if long {
            out.extend([0, 0]);
            out.extend(len.to_le_bytes());
        } else {
            out.extend((len as u16).to_le_bytes());
        }
        out.extend(value);
        out
    }

    fn file(data_set: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; 128];
        out.extend(b"DICM");
        out.extend(explicit_le((0x0002, 0x0010), b"UI", b"1.2.840.10008.1.2.1\0", false, None));
        out.extend(data_set);
        out
    }

    #[test]
    fn lengths_past_the_end_are_refused_naming_the_element_and_good_files_pass() {
        let good = file(&explicit_le((0x0010, 0x0010), b"PN", b"Doe^Jane", false, None));
        assert_eq!(check(&good), Ok(()));
        let huge = file(&explicit_le((0x7FE0, 0x0010), b"OW", &[0, 0, 0, 0], true, Some(0xF000_0000)));
        let e = check(&huge).unwrap_err();
        assert!(e.contains("(7FE0,0010)") && e.contains("4026531840"), "{e}");
        // A sequence of one item whose element claims too much: found by walking in.
        let inner = explicit_le((0x0008, 0x0100), b"SH", b"ab", false, Some(0x4000));
        let mut item = vec![0xFE, 0xFF, 0x00, 0xE0];
        item.extend((inner.len() as u32).to_le_bytes());
        item.extend(&inner);
        let seq = file(&explicit_le((0x0008, 0x1140), b"SQ", &item, true, None));
        let e = check(&seq).unwrap_err();
        assert!(e.contains("(0008,0100)"), "{e}");
        // Cut inside the last element.
        assert!(check(&good[..good.len() - 9]).is_err());
    }

    /// Every DICOM file pydicom ships that dicom-rs reads passes the check: it refuses no file
    /// the reader would take (explicit and implicit VR, big endian, encapsulated, no meta).
    #[test]
    fn files_pydicom_ships_that_dicom_rs_reads_pass() {
        let dir = std::path::Path::new("/usr/lib/python3/dist-packages/pydicom/data/test_files");
        let files: Vec<_> = std::fs::read_dir(dir).expect("python3-pydicom's test files (setup.sh installs them)").map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "dcm")).collect();
        let mut read = 0;
        for f in &files {
            if dicom_object::OpenFileOptions::new().open_file(f).is_ok() {
                read += 1;
                assert_eq!(check(&std::fs::read(f).unwrap()), Ok(()), "{}", f.display());
            }
        }
        assert!(read >= 30, "only {read} of {} files read", files.len());
    }

    #[test]
    fn files_the_writers_make_pass() {
        let v = crate::Phantom::new(&crate::PhantomSpec { dims: [16, 12, 4], spacing_mm: 0.5, ..Default::default() }).scan();
        let dir = tempfile::tempdir().unwrap();
        crate::write_dicom_series(&v, dir.path()).unwrap();
        for f in std::fs::read_dir(dir.path()).unwrap() {
            let bytes = std::fs::read(f.unwrap().path()).unwrap();
            assert_eq!(check(&bytes), Ok(()));
        }
    }
}
