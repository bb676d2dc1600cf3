// The controlling page's heartbeat, on a thread of its own: the page's thread can be busy
// for seconds drawing the 3D view (in software on a machine without a GPU), and that must not
// cost the page its control — a lapsed lease stops the arm. The page says when to beat: only
// while it controls and is seen (a hidden page lets its lease lapse: nobody sees Stop there).
let timer = null;

onmessage = ({ data }) => {
  clearInterval(timer);
  timer = data.beat ? setInterval(() => beat(data.headers), data.ms) : null;
};

async function beat(headers) {
  try {
    // Bounded: a studio that hangs must cost the page its claim of control, not stall it.
    const response = await fetch('/api/control', { method: 'POST', headers, body: '{}', signal: AbortSignal.timeout(2000) });
    postMessage({ ok: response.ok, answer: await response.json().catch(() => ({})) });
  } catch {
    postMessage({ ok: false, lost: true, answer: { error: 'the studio does not answer: keypose studio has ended or cannot be reached (keys are not sent)' } });
  }
}
