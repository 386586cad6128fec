// The preview's table: one row per method with its duration and whether it is feasible;
// an infeasible one shows the service's message and the field at fault (its code only as
// the tooltip), and the error line says the same.
import { $, COLORS, NAMES } from "./state.js";
import { showError, clearError, errorText } from "./ui.js";

function row(method, plan, sameAs = null) {
  const tr = document.createElement("tr");
  tr.dataset.method = method;
  const cell = (text, cls) => {
    const td = document.createElement("td");
    td.textContent = text;
    if (cls) td.className = cls;
    tr.appendChild(td);
    return td;
  };
  // Built node by node: the page's Content-Security-Policy forbids inline style markup.
  const swatch = document.createElement("span");
  swatch.className = "swatch";
  swatch.style.background = COLORS[method];
  cell("").appendChild(swatch);
  cell(NAMES[method] + (method === "kenlerp" ? " β=" + parseFloat($("beta").value).toFixed(2) : ""));
  const t = plan.traj && plan.traj.t;
  cell(t ? `${t[t.length - 1].toFixed(2)} s` : "–");
  if (t) {
    cell(`feasible · ${t.length} samples`, "ok");
  } else {
    const err = plan.error || {};
    const td = cell("", "bad plan-error");
    const message = err.message || "infeasible";
    if (sameAs) {
      // the same refusal as a row above: said once, not once per method
      td.append(`as ${NAMES[sameAs]}`);
    } else {
      // the field as a chip only when the message does not name it already
      if (err.field && !message.includes(err.field)) {
        const field = document.createElement("code");
        field.className = "field";
        field.textContent = err.field;
        td.append(field, " ");
      }
      td.append(message);
    }
    td.title = err.code ? `${err.code}: ${errorText(err)}` : errorText(err);
  }
  return tr;
}

/** Fill the table with [method, plan] results; `inputError` replaces them all. */
export function showPlans(results, inputError = null) {
  const tbody = $("plans").querySelector("tbody");
  if (inputError) { showError(inputError, "preview"); return; }
  // Methods refused with the same words share one line (four overlays of an unreachable
  // target are one refusal, not four)
  const first = new Map();
  const rows = results.map(([m, p]) => {
    const text = p.error ? errorText(p.error) : null;
    const earlier = text !== null && first.has(text) ? first.get(text) : null;
    if (text !== null && earlier === null) first.set(text, m);
    return row(m, p, earlier);
  });
  tbody.replaceChildren(...rows);
  const failed = results.filter(([, p]) => p.error);
  const main = results.length ? results[0][0] : null;
  if (failed.length) {
    const groups = new Map();
    failed.forEach(([m, p]) => {
      const text = errorText(p.error);
      if (!groups.has(text)) groups.set(text, []);
      groups.get(text).push(m);
    });
    showError([...groups].map(([text, methods]) =>
      (failed.length > 1 || methods[0] !== main ? methods.map((m) => NAMES[m]).join(", ") + ": "
        : "") + text).join("\n"), "preview");
  } else {
    clearError("preview");
  }
}
