//! The terminal front end: draws a [`TeachState`] and turns crossterm key presses into
//! [`Key`]s. It holds no rules of its own.
//!
//! The terminal is in raw mode on the alternate screen while the session runs, and is restored
//! on every way out: a normal return, an error (a guard's `Drop`), and a panic (ratatui's
//! `try_init` installs a hook that restores the terminal before the panic message prints).

use keypose::teach::format;
use keypose::teach::{apply, press, refresh, Session, TeachError};
use keypose::teach::{Activity, InputQueue, Key, MotionKind, TeachState, BINDINGS, MAX_WAITING};
use keypose::terminal_text::escape_field;
use ratatui::crossterm::event::{self, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Cell, Paragraph, Row, Table, TableState, Wrap};
use ratatui::Frame;
use std::time::{Duration, Instant};

/// How often the present pose is read while idle: 20 Hz, smooth to watch and a small share of
/// the bus.
pub const READ_PERIOD: Duration = Duration::from_millis(50);
/// The longest a signal waits for the arm to brake to rest before the session ends anyway.
const SIGNAL_BRAKE_WAIT: Duration = Duration::from_secs(10);
/// How often the end of a jog is looked for while keys wait for it.
const WAITING_POLL: Duration = Duration::from_millis(2);
/// Width of the limit bar, in cells.
const BAR_WIDTH: usize = 21;
/// Below this width the joint table and the key list are stacked instead of side by side.
const SIDE_BY_SIDE_WIDTH: u16 = 118;

/// Exit code after SIGTERM or SIGHUP: the command line's code for an interruption.
const EXIT_KILLED: i32 = 130;

/// Restores the terminal when dropped, whatever way the session ends.
struct RestoreTerminal;

impl Drop for RestoreTerminal {
    fn drop(&mut self) {
        ratatui::restore();
    }
}

/// Runs the session in the terminal until the user quits.
pub fn run(state: &mut TeachState, session: &mut Session) -> Result<(), TeachError> {
    // The guard comes first so that a failure half-way through initialisation still restores.
    let _restore = RestoreTerminal;
    // SIGTERM (kill) or SIGHUP (a closed terminal window) brakes a moving arm at once and ends
    // the session once it is at rest, all on the handler's thread: the terminal may be gone,
    // and the key loop with it. Nothing is lost by ending then: every edit is already in the
    // journal, and the servos hold their last goal. (Ctrl-C in raw mode is a key, not a
    // signal.)
    let brake = session.brake();
    keypose::stop::on_signal(move || {
        brake.soft_stop();
        brake.wait_until_at_rest(SIGNAL_BRAKE_WAIT);
        ratatui::restore();
        std::process::exit(EXIT_KILLED);
    });
    let mut terminal = ratatui::try_init()?;
    let bus = session.describe().to_string();
    let mut queue = InputQueue::default();
    let mut next_read = Instant::now();
    loop {
        if let Some(event) = session.poll()? {
            let follow = state.on_event(event);
            apply(state, session, follow);
        }
        if Instant::now() >= next_read {
            refresh(state, session);
            next_read = Instant::now() + READ_PERIOD;
        }
        while let Some(key) = queue.next(state.is_jogging()) {
            press(state, session, key);
        }
        terminal.draw(|frame| draw(frame, state, &bus))?;
        if state.should_quit() {
            return Ok(());
        }
        let mut timeout = next_read.saturating_duration_since(Instant::now());
        if !queue.is_empty() {
            timeout = timeout.min(WAITING_POLL);
        }
        // Every key that has arrived, before any is carried out: a stop among them drops the
        // ones before it. At most a queue's worth at a time: a terminal that hung up is always
        // "ready", and the loop must still come round to the signal that follows.
        let mut wait = timeout;
        for _ in 0..MAX_WAITING {
            if !event::poll(wait)? {
                break;
            }
            if let event::Event::Key(key_event) = event::read()? {
                if key_event.kind != KeyEventKind::Release {
                    if let Some(key) = map_key(key_event) {
                        queue.push(stop_not_quit(key, &queue));
                    }
                }
            }
            wait = Duration::ZERO;
        }
    }
}

/// Ctrl-C with keys still waiting is a stop (it drops them, as Esc does), not the quit it is
/// in an idle session with nothing queued: whoever presses it behind a flood of jogs wants the
/// arm to stop, not the session to end.
fn stop_not_quit(key: Key, queue: &InputQueue<Key>) -> Key {
    match key {
        Key::Interrupt if !queue.is_empty() => Key::Esc,
        key => key,
    }
}

/// A crossterm key press as a session key.
pub fn map_key(event: KeyEvent) -> Option<Key> {
    let shift = event.modifiers.contains(KeyModifiers::SHIFT);
    let control = event.modifiers.contains(KeyModifiers::CONTROL);
    Some(match event.code {
        KeyCode::Char('c') if control => Key::Interrupt,
        // The editors' undo and redo; without the mapping Ctrl+Z would jog the tool up.
        KeyCode::Char('z') if control && !shift => Key::Undo,
        KeyCode::Char('z' | 'Z' | 'y') if control => Key::Redo,
        KeyCode::Char(_) if control => return None,
        KeyCode::Char(c) => Key::Char(c),
        KeyCode::Up => Key::Up,
        KeyCode::Down => Key::Down,
        KeyCode::Left if shift => Key::ShiftLeft,
        KeyCode::Right if shift => Key::ShiftRight,
        KeyCode::Left => Key::Left,
        KeyCode::Right => Key::Right,
        KeyCode::Enter => Key::Enter,
        KeyCode::Esc => Key::Esc,
        KeyCode::Backspace => Key::Backspace,
        _ => return None,
    })
}

/// Draws the whole screen.
pub fn draw(frame: &mut Frame, state: &TeachState, bus: &str) {
    let help = help_lines(frame.area().width.saturating_sub(2) as usize);
    let [title, body, status, help_area] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(6),
        Constraint::Length(2),
        Constraint::Length(help.len() as u16 + 1),
    ])
    .areas(frame.area());
    frame.render_widget(title_line(state, bus), title);

    let [joints, keys] = if body.width >= SIDE_BY_SIDE_WIDTH {
        Layout::horizontal([Constraint::Min(70), Constraint::Length(46)]).areas(body)
    } else {
        let rows = state.robot().joints.len() as u16 + 3;
        Layout::vertical([Constraint::Length(rows), Constraint::Min(3)]).areas(body)
    };
    draw_joints(frame, joints, state);
    draw_keys(frame, keys, state);
    frame.render_widget(status_lines(state), status);
    frame.render_widget(
        Paragraph::new(help).block(Block::new().title(Line::styled(
            " keys ",
            Style::new().add_modifier(Modifier::BOLD),
        ))),
        help_area,
    );
}

fn title_line(state: &TeachState, bus: &str) -> Line<'static> {
    let dirty = if state.is_dirty() { " (unsaved)" } else { "" };
    let timing = match state.list().sequence().key_interval {
        Some(interval) => format!("{interval:.1} s between keys"),
        None => format!("timed keys, speed ×{:.1}", state.speed()),
    };
    Line::from(vec![
        Span::styled("keypose teach", Style::new().add_modifier(Modifier::BOLD)),
        Span::raw(format!(
            "  {} on {bus}  ·  {}{dirty}  ·  {timing}",
            escape_field(&state.robot().name),
            escape_field(&state.output().display().to_string())
        )),
    ])
}

fn draw_joints(frame: &mut Frame, area: Rect, state: &TeachState) {
    let robot = state.robot();
    let key = state.list().show();
    let bearing = state.weight_bearing();
    let rows = robot.joints.iter().enumerate().map(|(j, joint)| {
        let present = state.present().get(j).copied().unwrap_or(f64::NAN);
        let key_value = key.and_then(|k| k.value(&joint.name));
        let key_number = key_value.and_then(|v| format::key_number(joint, v));
        let key_text = key_value.map_or("·".into(), |v| format::key_text(joint, v));
        let (torque, torque_style) = if state.torque()[j] {
            ("hold", Style::new().fg(Color::Green))
        } else {
            ("limp", Style::new().fg(Color::Yellow))
        };
        let marker = if j == state.selected() { "▶ " } else { "  " };
        let row = Row::new(vec![
            Cell::from(format!("{marker}{}", escape_field(&joint.name))),
            Cell::from(format::value_and_percent(joint, present)),
            Cell::from(key_text),
            Cell::from(limit_bar(joint, present, key_number)),
            Cell::from(Span::styled(torque, torque_style)),
            Cell::from(if bearing[j] { "load" } else { "" }),
        ]);
        if j == state.selected() {
            row.style(Style::new().add_modifier(Modifier::BOLD))
        } else {
            row
        }
    });
    // "▶ " and the longest name: a cell's `ARM/JOINT` names are longer than one arm's.
    let name_width = state
        .robot()
        .joints
        .iter()
        .map(|j| j.name.chars().count() + 2)
        .fold(18, usize::max) as u16;
    let table = Table::new(
        rows,
        [
            Constraint::Length(name_width),
            // "-87.9° 100%": degrees with the percent of a calibrated range beside them.
            Constraint::Length(12),
            Constraint::Length(12),
            Constraint::Length(BAR_WIDTH as u16 + 2),
            Constraint::Length(5),
            Constraint::Length(5),
        ],
    )
    .header(
        Row::new(vec!["  joint", "present", "key", "limits", "", ""])
            .style(Style::new().add_modifier(Modifier::UNDERLINED)),
    )
    .block(
        Block::bordered()
            .title(" joints  (● present  ◆ current key; load: carries the arm's weight) ")
            .title_bottom(tool_title(state)),
    );
    frame.render_widget(table, area);
}

/// Where the tool (the robot's tcp) is at the present pose, base frame, millimetres: what a
/// tool key (`"tool": {"xyz": …}`, metres) would say; on a cell each arm's, in its own base
/// frame. Blank until every joint has been read.
fn tool_title(state: &TeachState) -> String {
    let present = state.present();
    if present.len() != state.robot().joints.len() || present.iter().any(|v| !v.is_finite()) {
        return String::new();
    }
    let tools: Vec<String> = keypose::teach::tool_positions(state.robot(), present)
        .into_iter()
        .map(|(arm, p)| {
            let p = p * 1000.0;
            let [x, y, z] = p.to_array().map(no_negative_zero);
            let at = format!("x {x:.1}  y {y:.1}  z {z:.1} mm");
            match arm {
                Some(arm) => format!("{arm} at {at}"),
                None => format!("at {at}"),
            }
        })
        .collect();
    format!(" tool {} ", tools.join(" · "))
}

/// `v` rounded to a tenth, with a value a hair below zero shown as 0.0 rather than −0.0.
fn no_negative_zero(v: f64) -> f64 {
    let rounded = (v * 10.0).round() / 10.0;
    if rounded == 0.0 {
        0.0
    } else {
        rounded
    }
}

/// `[──◆───●──]`: where the present value (●) and the key's value (◆) sit between the limits.
fn limit_bar(joint: &keypose::robot::Joint, present: f64, key: Option<f64>) -> Line<'static> {
    let (min, max) = (joint.limits.min, joint.limits.max);
    let cell = |v: f64| -> Option<usize> {
        v.is_finite().then(|| {
            (((v - min) / (max - min)).clamp(0.0, 1.0) * (BAR_WIDTH - 1) as f64).round() as usize
        })
    };
    let mut spans = vec![Span::raw("[")];
    let (p, k) = (cell(present), key.and_then(cell));
    for i in 0..BAR_WIDTH {
        spans.push(if Some(i) == p {
            Span::styled("●", Style::new().fg(Color::Yellow))
        } else if Some(i) == k {
            Span::styled("◆", Style::new().fg(Color::Cyan))
        } else {
            Span::styled("─", Style::new().fg(Color::DarkGray))
        });
    }
    spans.push(Span::raw("]"));
    Line::from(spans)
}

fn draw_keys(frame: &mut Frame, area: Rect, state: &TeachState) {
    let sequence = state.list().sequence();
    let rows = sequence.keyframes.iter().enumerate().map(|(i, key)| {
        Row::new(vec![
            Cell::from(i.to_string()),
            Cell::from(escape_field(key.name.as_deref().unwrap_or_default()).into_owned()),
            Cell::from(format!("{:.2}", sequence.key_time(i))),
            Cell::from(if key.hold > 0.0 {
                format!("{:.2}", key.hold)
            } else {
                String::new()
            }),
            Cell::from(segment_mode(sequence, i)),
        ])
    });
    let table = Table::new(
        rows,
        [
            Constraint::Length(4),
            Constraint::Min(8),
            Constraint::Length(8),
            Constraint::Length(6),
            Constraint::Length(9),
        ],
    )
    .header(
        Row::new(vec!["#", "name", "time s", "hold", "to next"])
            .style(Style::new().add_modifier(Modifier::UNDERLINED)),
    )
    .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
    .highlight_symbol("▶ ")
    // The default mode is named here, beside the segments that follow it.
    .block(Block::bordered().title(format!(
        " keys ({}), default {} ",
        sequence.keyframes.len(),
        sequence.interpolation.name()
    )));
    let mut table_state = TableState::default();
    if !sequence.keyframes.is_empty() {
        table_state.select(Some(state.list().current_index()));
    }
    frame.render_stateful_widget(table, area, &mut table_state);
}

/// The mode of the segment from key `i` (none after the last key); `*` marks a key's own
/// mode, the rest follow the default shown in the title.
fn segment_mode(sequence: &keypose::sequence::Sequence, i: usize) -> String {
    if i + 1 >= sequence.keyframes.len() {
        return String::new();
    }
    let mode = format::segment_interp(sequence, i).name();
    match sequence.keyframes[i].interp {
        Some(_) => format!("{mode}*"),
        None => mode.to_string(),
    }
}

fn status_lines(state: &TeachState) -> Paragraph<'static> {
    let first = match format::question(state) {
        Some(question) => Line::styled(
            format!("? {}", escape_field(&question.to_string())),
            Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD),
        ),
        None => {
            let status = state.status();
            let style = if status.error {
                Style::new().fg(Color::Red)
            } else {
                Style::new()
            };
            Line::styled(escape_field(&status.text).into_owned(), style)
        }
    };
    let activity = match state.activity() {
        Activity::Idle => "idle".to_string(),
        Activity::Moving { kind, stops, .. } => {
            let what = match kind {
                MotionKind::ToKey(i) => format!("moving to key {i}"),
                MotionKind::Play { from } => format!("playing from key {from}"),
                MotionKind::Jog => "jogging".to_string(),
            };
            if *stops > 0 {
                format!("{what}, stopping")
            } else {
                what
            }
        }
    };
    let journal = match state.journal() {
        Some(j) => format!("journal {}", j.path().display()),
        None => "no journal (no cache directory)".into(),
    };
    let second = Line::styled(
        format!("{activity}  ·  {journal}"),
        Style::new().fg(Color::DarkGray),
    );
    Paragraph::new(vec![first, second]).wrap(Wrap { trim: true })
}

/// The bindings, packed into as few lines as `width` allows.
fn help_lines(width: usize) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    let mut spans: Vec<Span<'static>> = Vec::new();
    let mut used = 0;
    for binding in BINDINGS {
        let len = binding.keys.chars().count() + binding.short.chars().count() + 4;
        if used > 0 && used + len > width {
            lines.push(Line::from(std::mem::take(&mut spans)));
            used = 0;
        }
        spans.push(Span::styled(
            binding.keys,
            Style::new().fg(Color::Cyan).add_modifier(Modifier::BOLD),
        ));
        spans.push(Span::raw(format!(" {}   ", binding.short)));
        used += len;
    }
    if !spans.is_empty() {
        lines.push(Line::from(spans));
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use keypose::robot::Robot;
    use keypose::sequence::{KeyframeList, Sequence};

    /// On a cell the tool line gives each arm's tool in its own base frame: at home both are
    /// where docs/robots.md §1.3 measured MuJoCo's gripperframe, 391.4 mm ahead, wherever the
    /// arm stands.
    #[test]
    fn the_tool_line_of_a_cell_names_each_arm() {
        let so101 = Robot::builtin("so101").expect("built in");
        let apart = |y: f64| {
            keypose::pose::RigidTransform::new(glam::DVec3::new(0.0, y, 0.0), glam::DQuat::IDENTITY)
        };
        let cell = Robot::cell(vec![
            ("left".into(), so101.clone(), apart(0.2)),
            ("right".into(), so101, apart(-0.2)),
        ])
        .expect("a cell");
        let present = cell.home.clone();
        let state = TeachState::new(
            cell,
            KeyframeList::new(Sequence::new_cell(Vec::new())),
            "taught.json".into(),
            None,
            present,
        );
        let title = tool_title(&state);
        assert!(
            title.contains("tool left at x 391.4") && title.contains("· right at x 391.4"),
            "{title}"
        );
    }
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    #[test]
    fn shift_arrows_jog_by_ten() {
        let key = |code, modifiers| map_key(KeyEvent::new(code, modifiers));
        assert_eq!(
            key(KeyCode::Left, KeyModifiers::SHIFT),
            Some(Key::ShiftLeft)
        );
        assert_eq!(key(KeyCode::Right, KeyModifiers::NONE), Some(Key::Right));
        assert_eq!(
            key(KeyCode::Char('c'), KeyModifiers::CONTROL),
            Some(Key::Interrupt)
        );
        assert_eq!(
            key(KeyCode::Char('z'), KeyModifiers::CONTROL),
            Some(Key::Undo)
        );
        assert_eq!(
            key(
                KeyCode::Char('Z'),
                KeyModifiers::CONTROL | KeyModifiers::SHIFT
            ),
            Some(Key::Redo)
        );
        assert_eq!(
            key(KeyCode::Char('y'), KeyModifiers::CONTROL),
            Some(Key::Redo)
        );
        assert_eq!(
            key(KeyCode::Char('T'), KeyModifiers::SHIFT),
            Some(Key::Char('T'))
        );
    }

    #[test]
    fn the_screen_shows_joints_keys_status_and_help() {
        let robot = Robot::builtin("so101").expect("built in");
        let present = robot.home.clone();
        let mut state = TeachState::new(
            robot,
            KeyframeList::new(Sequence::new("so101")),
            "taught.json".into(),
            None,
            present,
        );
        let _ = state.handle_key(Key::Char('n'));
        let _ = state.handle_key(Key::Char('n'));
        let _ = state.handle_key(Key::Char('<'));
        let _ = state.handle_key(Key::Char('p'));
        // The smallest usual terminal, and a wide one (side by side).
        for (width, height) in [(80, 24), (140, 30)] {
            let mut terminal = Terminal::new(TestBackend::new(width, height)).expect("terminal");
            terminal
                .draw(|frame| draw(frame, &state, "virtual"))
                .expect("draws");
            let screen: String = terminal
                .backend()
                .buffer()
                .content()
                .iter()
                .map(|c| c.symbol())
                .collect();
            for text in [
                "gripper",
                "limp",
                "step",
                "jog 1°",
                "quit",
                "▶ 0",
                "default monotone",
                // The tool at home, where docs/robots.md §1.3 measured MuJoCo's gripperframe:
                // (0.39136, −0.00001, 0.22647) m.
                "tool at x 391.4",
                "z 226.5 mm",
            ] {
                assert!(screen.contains(text), "{text:?} missing at width {width}");
            }
        }
    }
}
