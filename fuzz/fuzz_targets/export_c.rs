//! `export c`'s header for a trajectory of a built-in robot whose joints, and the source
//! file, are renamed with any text at all.
//! Property: no panic; read as a C compiler reads it (trigraphs, line splicing, comments,
//! literals: `keypose_fuzz::c_text`), its string literals are exactly the include, the source
//! and every joint's name, byte for byte, and everything else — code and comments — is the
//! header of the same trajectory under the robot's own names: no name reaches the code.
//! (That the header compiles with gcc -Wall -Werror and runs is tests/commands/export_c.rs's.)
#![no_main]

use keypose::interop::c_export;
use keypose_fuzz::c_text::lex;
use keypose_fuzz::exports::{names, renamed, rest_as_name, trajectory};
use keypose_fuzz::Choices;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let Some((robot, trajectory)) = trajectory(&mut choices) else {
        return;
    };
    let names = names(&mut choices, robot.joints.len());
    let source = rest_as_name(&mut choices);
    let hostile = renamed(robot, &names);
    let Ok(header) = c_export::header(&trajectory, &hostile, &source) else {
        return;
    };
    let plain = c_export::header(&trajectory, robot, "seq.json")
        .expect("the same trajectory under its own names exports");
    let lexed = lex(&header).unwrap_or_else(|e| panic!("not C: {e}\n{header}"));
    let mut expected: Vec<Vec<u8>> = vec![b"keypose_player.h".to_vec(), source.into_bytes()];
    expected.extend(names.into_iter().map(String::into_bytes));
    assert_eq!(
        lexed.literals, expected,
        "the literals are not the names\n{header}"
    );
    let reference = lex(&plain).expect("keypose's own header reads as C");
    assert_eq!(
        lexed.skeleton, reference.skeleton,
        "a name changed the header outside its string literal"
    );
});
