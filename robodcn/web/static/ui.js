// Messages on the page: the error line, the token box, the link pill. Errors are the
// service's error bodies ({code, message, field, …}); the page shows the message and the
// field, never the bare code.
import { $ } from "./state.js";

/** The words of an error body: "field: message" unless the message names the field. */
export function errorText(err) {
  if (typeof err === "string") return err;
  if (!err) return "error";
  const message = err.message || err.code || "error";
  return err.field && !message.includes(err.field) ? `${err.field}: ${message}` : message;
}

/** Show `err`; `source` says what it answers ("preview": the plan table's previews). */
export function showError(err, source = "action") {
  const el = $("error");
  el.textContent = errorText(err);
  el.dataset.source = source;
}

/** Clear the error line; with `source`, only an error that source showed: a preview that
 * plans fine must not wipe what a refused Move or operation said a moment before. */
export function clearError(source = null) {
  const el = $("error");
  if (source !== null && el.textContent && el.dataset.source !== source) return;
  el.textContent = "";
}

export function showTokenBox() {
  $("token-box").hidden = false;
}

export function setLink(text, ok) {
  const el = $("link");
  el.textContent = text;
  el.className = "pill " + (ok ? "ok" : "bad");
}
