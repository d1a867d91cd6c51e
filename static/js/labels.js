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
			tag.hidden = true;
			const text = document.createElement( 'span' );
			text.textContent = name;
			const note = document.createElement( 'span' );
			note.className = 'note';
			note.hidden = true;
			tag.append( text, note );
			tag.style.color = `#${view.color.getHexString()}`;
			this.container.append( tag );
			this._tags.set( name, { tag, note } );

		}

	}

	refreshColors( views ) {

		for ( const [ name, { tag } ] of this._tags ) {

			const view = views.get( name );
			if ( view ) tag.style.color = `#${view.color.getHexString()}`;

		}

	}

	update( views, camera ) {

		const width = this.container.clientWidth;
		const height = this.container.clientHeight;
		for ( const [ name, { tag, note } ] of this._tags ) {

			const view = views.get( name );
			const text = view ? view.note : null;
			if ( note.textContent !== ( text ?? '' ) ) note.textContent = text ?? '';
			note.hidden = ! text;
			if ( ! view || ! view.anchor || ! view.group.visible ) {

				tag.hidden = true;
				continue;

			}
			_ndc.copy( view.anchor ).project( camera );
			const onScreen = _ndc.z < 1 && Math.abs( _ndc.x ) < 1.1 && Math.abs( _ndc.y ) < 1.1;
			tag.hidden = ! onScreen;
			if ( onScreen ) {

				const x = ( _ndc.x + 1 ) / 2 * width;
				const y = ( 1 - _ndc.y ) / 2 * height;
				tag.style.left = `${x.toFixed( 1 )}px`;
				tag.style.top = `${y.toFixed( 1 )}px`;

			}

		}

	}

	dispose() {

		this.container.replaceChildren();
		this._tags.clear();

	}

}

export { Labels };
