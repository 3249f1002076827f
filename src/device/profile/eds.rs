//! The PDO mapping a node starts with, read from its EDS (CiA 306): the `DefaultValue`s of
//! the communication (1400h/1800h) and mapping (1600h/1A00h) parameters, with `$NODEID`
//! resolved.

use super::mapping::{Direction, MappedObject, Pdo, COB_ID_INVALID};
use std::collections::BTreeMap;

/// Why an EDS does not give a usable mapping; the message names the section and key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{section}: {reason}")]
pub struct EdsError {
    pub section: String,
    pub reason: String,
}

/// Sections and their keys, names upper-cased (CiA 306 section names are not case sensitive).
fn parse_ini(text: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut section = String::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with(';') {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.trim().to_ascii_uppercase();
            out.entry(section.clone()).or_default();
        } else if let Some((k, v)) = line.split_once('=') {
            out.entry(section.clone())
                .or_default()
                .insert(k.trim().to_ascii_uppercase(), v.trim().to_string());
        }
    }
    out
}

/// A CiA 306 number: decimal, `0x` hex or octal with a leading 0, optionally `$NODEID+`
/// or `+$NODEID` (§4.6.3).
fn number(text: &str, node_id: u8) -> Option<u64> {
    let mut total = 0u64;
    for term in text.split('+') {
        let t = term.trim();
        if t.eq_ignore_ascii_case("$NODEID") {
            total += u64::from(node_id);
        } else if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
            total += u64::from_str_radix(h, 16).ok()?;
        } else if t.len() > 1 && t.starts_with('0') {
            total += u64::from_str_radix(&t[1..], 8).ok()?;
        } else {
            total += t.parse::<u64>().ok()?;
        }
    }
    Some(total)
}

/// Every PDO the EDS defines (communication and mapping parameters both present), RPDOs then
/// TPDOs, with their default COB-IDs, transmission types and mappings for node `node_id`.
pub fn pdos_from_eds(text: &str, node_id: u8) -> Result<Vec<Pdo>, EdsError> {
    let ini = parse_ini(text);
    let value = |index: u16, sub: u8| -> Result<Option<u64>, EdsError> {
        let section = format!("{index:04X}SUB{sub:X}");
        let Some(keys) = ini.get(&section) else {
            return Ok(None);
        };
        let Some(raw) = keys.get("DEFAULTVALUE") else {
            return Ok(None);
        };
        number(raw, node_id).map(Some).ok_or_else(|| EdsError {
            section: format!("[{index:04X}sub{sub:X}]"),
            reason: format!("DefaultValue {raw:?} is not a number"),
        })
    };
    let mut out = Vec::new();
    for (direction, comm_base, map_base) in [
        (Direction::Receive, 0x1400u16, 0x1600u16),
        (Direction::Transmit, 0x1800, 0x1A00),
    ] {
        for n in 0..512u16 {
            let (comm, map) = (comm_base + n, map_base + n);
            if !ini.contains_key(&format!("{comm:04X}")) || !ini.contains_key(&format!("{map:04X}"))
            {
                continue;
            }
            let missing = |index: u16, sub: u8| EdsError {
                section: format!("[{index:04X}sub{sub:X}]"),
                reason: "missing, or without a DefaultValue".into(),
            };
            let cob = value(comm, 1)?.ok_or_else(|| missing(comm, 1))? as u32;
            let transmission_type = value(comm, 2)?.ok_or_else(|| missing(comm, 2))? as u8;
            let count = value(map, 0)?.ok_or_else(|| missing(map, 0))?;
            if count > 64 {
                return Err(EdsError {
                    section: format!("[{map:04X}sub0]"),
                    reason: format!("{count} mapped objects: at most 64"),
                });
            }
            let mut objects = Vec::new();
            for sub in 1..=count as u8 {
                let v = value(map, sub)?.ok_or_else(|| missing(map, sub))?;
                objects.push(MappedObject::from_u32(v as u32));
            }
            let pdo = Pdo {
                direction,
                number: n + 1,
                cob_id: cob & 0x7FF,
                enabled: cob & COB_ID_INVALID == 0,
                transmission_type,
                objects,
            };
            if pdo.bits() > 64 {
                return Err(EdsError {
                    section: format!("[{map:04X}]"),
                    reason: format!("maps {} bits: a PDO carries at most 64", pdo.bits()),
                });
            }
            out.push(pdo);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const EDS: &str = "[1800]\r\nSubNumber=3\r\n[1800sub1]\r\nDefaultValue=$NODEID+0x180\r\n\
        [1800sub2]\r\nDefaultValue=1\r\n[1A00]\r\n[1A00sub0]\r\nDefaultValue=2\r\n\
        [1A00sub1]\r\nDefaultValue=0x60410010\r\n[1A00sub2]\r\nDefaultValue=0x60640020\r\n\
        [1801]\r\n[1801sub1]\r\nDefaultValue=0x80000280\r\n[1801sub2]\r\nDefaultValue=255\r\n\
        [1A01]\r\n[1A01sub0]\r\nDefaultValue=0\r\n";

    #[test]
    fn reads_the_default_mapping_with_the_node_id() {
        let pdos = pdos_from_eds(EDS, 16).expect("valid");
        assert_eq!(pdos.len(), 2);
        assert_eq!(pdos[0].cob_id, 0x190);
        assert!(pdos[0].enabled);
        assert_eq!(
            pdos[0].objects,
            vec![
                MappedObject::new(0x6041, 0, 16),
                MappedObject::new(0x6064, 0, 32)
            ]
        );
        assert!(!pdos[1].enabled);
        assert_eq!(pdos[1].transmission_type, 255);
    }

    #[test]
    fn a_missing_entry_is_named() {
        let broken = EDS.replace("[1A00sub2]\r\nDefaultValue=0x60640020\r\n", "");
        let e = pdos_from_eds(&broken, 16).expect_err("entry 2 missing");
        assert_eq!(e.section, "[1A00sub2]");
        assert_eq!(number("0x180+$NODEID", 5), Some(0x185));
        assert_eq!(number("010", 5), Some(8));
        assert_eq!(number("x", 5), None);
    }
}
