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

export function showError(err) {
  $("error").textContent = errorText(err);
}

export function clearError() {
  $("error").textContent = "";
}

export function showTokenBox() {
  $("token-box").hidden = false;
}

export function setLink(text, ok) {
  const el = $("link");
  el.textContent = text;
  el.className = "pill " + (ok ? "ok" : "bad");
}
