// The one line that says what is wrong, and does not flicker.

const HOLD_MS = 1000; // a new problem (other than the server) must last this long to be shown
const CLEAR_MS = 300; // and "all is well" this long to hide the banner

/**
 * Decides the banner from the most important current problem, with
 * hysteresis: the server connection's state shows at once (it is the reason for
 * everything else), anything else only once it has lasted HOLD_MS, and the
 * banner hides once all has been well for CLEAR_MS. Texts are built so they do
 * not change while the state they describe lasts (no ages, no countdowns).
 */
class Banner {

	constructor( el ) {

		this.el = el;
		this.text = null; // shown now
		this.warn = false;
		this.changes = 0;
		this._want = null; // { text, warn, urgent, since }

	}

	/** The problem as of `now` (ms): `{ text, warn, urgent }` or null. */
	update( problem, now ) {

		const text = problem ? problem.text : null;
		if ( this._want === null || this._want.text !== text ) this._want = { ...problem, text, since: now };
		const want = this._want;
		if ( want.text === this.text ) {

			this._show( want.text, want.warn );
			return;

		}
		const hold = want.text === null ? CLEAR_MS : want.urgent ? 0 : HOLD_MS;
		if ( now - want.since >= hold ) this._show( want.text, want.warn );

	}

	_show( text, warn ) {

		if ( text !== this.text ) {

			this.text = text;
			this.changes ++;
			this.el.hidden = text === null;
			this.el.textContent = text ?? '';

		}
		if ( warn !== this.warn ) {

			this.warn = Boolean( warn );
			this.el.classList.toggle( 'warn', this.warn );

		}

	}

}

export { Banner };
