// The two side panels: collapsible, collapsed by default on narrow screens, and
// reported to the scene so framing keeps the robots in the part they leave free.

const NARROW = '(max-width: 800px)';
const GAP_PX = 14; // panels sit this far from the window's edge

class Panels {

	constructor( root, onInsets ) {

		this.onInsets = onInsets; // (leftPx, rightPx) => void
		this.narrow = window.matchMedia( NARROW );
		this.panels = [ ...root.querySelectorAll( '.panel' ) ].map( ( panel ) => {

			const toggle = panel.querySelector( '.panel-toggle' );
			const entry = { panel, toggle };
			toggle.addEventListener( 'click', () => this.setOpen( entry, panel.classList.contains( 'collapsed' ) ) );
			return entry;

		} );
		this._onNarrow = () => this._defaults();
		this.narrow.addEventListener( 'change', this._onNarrow );
		this._observer = new ResizeObserver( () => this._report() );
		for ( const { panel } of this.panels ) this._observer.observe( panel );
		this._defaults();

	}

	// Narrow screens start with both panels collapsed, so they never cover the robots.
	_defaults() {

		for ( const entry of this.panels ) this.setOpen( entry, ! this.narrow.matches );

	}

	setOpen( entry, open ) {

		const { panel, toggle } = entry;
		panel.classList.toggle( 'collapsed', ! open );
		toggle.setAttribute( 'aria-expanded', String( open ) );
		const what = panel.getAttribute( 'aria-label' ) || 'panel';
		toggle.setAttribute( 'aria-label', `${open ? 'collapse' : 'expand'} ${what.toLowerCase()}` );
		toggle.textContent = open ? '−' : '+';
		this._report();

	}

	_report() {

		if ( this.narrow.matches ) {

			this.onInsets( 0, 0 ); // panels float over the view; only their headers when collapsed
			return;

		}
		let left = 0;
		let right = 0;
		for ( const { panel } of this.panels ) {

			if ( panel.classList.contains( 'collapsed' ) ) continue;
			const width = panel.getBoundingClientRect().width + GAP_PX;
			if ( panel.classList.contains( 'panel-left' ) ) left = width;
			else right = width;

		}
		this.onInsets( left, right );

	}

	dispose() {

		this.narrow.removeEventListener( 'change', this._onNarrow );
		this._observer.disconnect();

	}

}

export { Panels };
