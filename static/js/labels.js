import * as THREE from 'three';

const _ndc = new THREE.Vector3();

/**
 * Robot name tags that follow the robots on screen (HTML, so they stay crisp),
 * with a robot's note beside its name while it is not live (its error, or why
 * it is grey).
 */
class Labels {

	constructor( container ) {

		this.container = container;
		this._tags = new Map(); // robot name -> element

	}

	/** One tag per view, coloured like the robot. */
	rebuild( views ) {

		this.container.replaceChildren();
		this._tags.clear();
		for ( const [ name, view ] of views ) {

			const tag = document.createElement( 'div' );
			tag.className = 'label';
			tag.dataset.robot = name;
			tag.hidden = true;
			const text = document.createElement( 'span' );
			text.textContent = name;
			const note = document.createElement( 'span' );
			note.className = 'note';
			note.hidden = true;
			tag.append( text, note );
			tag.style.color = `#${view.color.getHexString()}`;
			this.container.append( tag );
			this._tags.set( name, { tag, note, x: null, y: null } );

		}

	}

	refreshColors( views ) {

		for ( const [ name, { tag } ] of this._tags ) {

			const view = views.get( name );
			if ( view ) tag.style.color = `#${view.color.getHexString()}`;

		}

	}

	/** Move each tag to its robot's anchor as `stage` (scene.js) shows it. */
	update( views, stage ) {

		for ( const [ name, entry ] of this._tags ) {

			const { tag, note } = entry;
			const view = views.get( name );
			const text = view ? view.note : null;
			if ( note.textContent !== ( text ?? '' ) ) note.textContent = text ?? '';
			if ( note.hidden !== ! text ) note.hidden = ! text;
			if ( ! view || ! view.anchor || ! view.group.visible ) {

				if ( ! tag.hidden ) tag.hidden = true;
				continue;

			}
			_ndc.copy( view.anchor ).project( stage.camera );
			const onScreen = _ndc.z < 1 && Math.abs( _ndc.x ) < 1.1 && Math.abs( _ndc.y ) < 1.1;
			if ( tag.hidden === onScreen ) tag.hidden = ! onScreen;
			if ( onScreen ) {

				// Style writes cost layout work every frame: only when the tag moved a pixel.
				const at = stage.toContainer( _ndc );
				const x = Math.round( at.x );
				const y = Math.round( at.y );
				if ( x !== entry.x || y !== entry.y ) {

					entry.x = x;
					entry.y = y;
					tag.style.transform = `translate(${x}px, ${y}px) translate(-50%, -100%)`;

				}

			}

		}

	}

	dispose() {

		this.container.replaceChildren();
		this._tags.clear();

	}

}

export { Labels };
