// The connection to the studio: every request gets an answer, and a lost studio is said.
// A request the studio does not answer (it has ended, crashed or hangs) resolves as a refusal
// saying so instead of failing silently, and the page stops claiming control once the studio
// is gone: the event stream breaks at once when the server ends, and the heartbeat's request,
// bounded in time, notices a server that hangs.

// How long a request may take before the studio counts as not answering. A live studio on a
// loaded machine can take seconds to answer a key or a tool target (measured: over 2 s beside
// busy processes); that answer is still its answer, so the bound is generous. A studio that is
// gone is said sooner: its event stream breaks at once, and the heartbeat, bounded at 2 s,
// takes the page out of control. Simulate runs MuJoCo for seconds and has its own bound.
export const ANSWER_MS = 15000;
export const SIMULATE_MS = 120000;
export const NO_ANSWER = 'the studio does not answer: keypose studio has ended or cannot be reached (keys are not sent)';

// fetch, answered within `ms` by the server's answer or by a refusal saying it did not come.
export async function request(path, init, ms = ANSWER_MS) {
  try {
    const response = await fetch(path, { ...init, signal: AbortSignal.timeout(ms) });
    const answer = await response.json().catch(() => ({}));
    return { ok: response.ok, status: response.status, answer };
  } catch {
    return { ok: false, status: 0, answer: { error: NO_ANSWER }, lost: true };
  }
}

// Calls `onLost` once the event stream is broken and stays so (the browser retries it; a
// studio that has ended never answers again), and `onBack` if it comes back.
export function watchStream(events, onLost, onBack) {
  let lost = false;
  events.addEventListener('error', () => {
    if (!lost) { lost = true; onLost(); }
  });
  events.addEventListener('open', () => {
    if (lost) { lost = false; onBack(); }
  });
}
