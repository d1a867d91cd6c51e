// Which view draws the cell, 3D (WebGL) or 2D (Canvas 2D), and the badge that says
// why the 2D one is shown. Without WebGL it is the only one; with WebGL the user may
// pick it (the View select, or ?view=2d in the address, which the select keeps up to
// date so that a reload or a bookmark keeps the choice).

const WHY = {
	none: 'this browser has no WebGL.',
	chosen: 'chosen under View.',
};

/** The view the address asks for: '2d' or '3d'. */
function askedView( search = window.location.search ) {

	return new URLSearchParams( search ).get( 'view' ) === '2d' ? '2d' : '3d';

}

/** The View select and the 2D view's badge, kept in step with `stage` (scene.js). */
class ViewChoice {

	constructor( root, stage ) {

		this.stage = stage;
		this.select = root.getElementById( 'view-kind' );
		this.badge = root.getElementById( 'view-badge' );
		this.reason = root.getElementById( 'view-badge-why' );
		this.howTo = root.getElementById( 'view-badge-how' );
		this.select.querySelector( 'option[value="3d"]' ).disabled = ! stage.webgl;
		this.select.addEventListener( 'change', () => this.pick( this.select.value ) );
		this._show();

	}

	/** Draw with `view` ('2d' or '3d'; '3d' only where there is WebGL) from now on. */
	pick( view ) {

		this.stage.setView( view );
		const address = new URL( window.location.href );
		if ( this.stage.view === '2d' ) address.searchParams.set( 'view', '2d' );
		else address.searchParams.delete( 'view' );
		window.history.replaceState( window.history.state, '', address.pathname + address.search + address.hash );
		this._show();

	}

	/** The view and what its badge says: { view, shown, text, pending (coarse meshes on their way) }. */
	shown() {

		const text = this.badge.hidden ? '' : this.badge.innerText.trim();
		return { view: this.stage.view, shown: ! this.badge.hidden, text, pending: this.stage.renderer.coarse?.pending ?? 0 };

	}

	_show() {

		const flat = this.stage.view === '2d';
		this.select.value = this.stage.view;
		this.badge.hidden = ! flat;
		this.reason.textContent = this.stage.webgl ? WHY.chosen : WHY.none;
		this.howTo.hidden = this.stage.webgl; // how to turn WebGL on: only where it is off

	}

}

export { ViewChoice, askedView };
